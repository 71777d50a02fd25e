// The sample search's generations in the preview: the scrubber (a
// generation's model, or the search's result) and the Play button's
// replay of the search, step by step.

import { $ } from './dom.js';
import { type PlayAt, SearchPlayer, isSearchResult, playButtonView, scrubberView } from './generation.js';
import type { App } from './main.js';
import type { PreviewResult, SampleInfo } from './protocol.js';

export class Playback {
  /** The Play button's replay of the search, and the wait before its next step. */
  readonly player = new SearchPlayer();
  private playTimer: ReturnType<typeof setTimeout> | undefined;

  constructor(private readonly app: App) {}

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    const scrubber = $<HTMLInputElement>('generation');
    scrubber.addEventListener('input', () => {
      // Moved by hand: a replay stops, the scrubber is where it was put.
      this.stopPlay();
      this.app.state.setGeneration(Number(scrubber.value), this.shownSample()?.generations ?? 0);
      // A move of the scrubber: merged with the next ones while a model is on its way, as the sliders' are.
      this.app.regrow(performance.now(), false);
    });
    // Released: the last position does not wait for a stale model.
    scrubber.addEventListener('change', () => this.app.released(performance.now(), false));
    // Back to the end, the search's result.
    scrubber.addEventListener('dblclick', () => {
      this.stopPlay();
      if (this.app.state.generation === null) return;
      this.app.state.showResult();
      this.app.regrow();
    });
    $('generation-play').addEventListener('click', () => this.togglePlay());
    // Space on the slider (which does nothing with it) plays and pauses, as in a video player.
    scrubber.addEventListener('keydown', (e) => {
      if (e.key !== ' ' || e.ctrlKey || e.metaKey || e.altKey) return;
      e.preventDefault();
      // Held down: one toggle, not one per repeat.
      if (!e.repeat) this.togglePlay();
    });
  }

  /** The last search's sample info (its number of generations), if the last model is a sample system's. */
  private shownSample(): SampleInfo | null {
    return this.app.last?.mode === 'sample' ? this.app.last.sample : null;
  }

  /** The generation scrubber: hidden in derive mode; its range is the last search's generations, its position the state's. */
  refreshScrubber(): void {
    // Anything that moved the scrubber (a new search puts it back at the end) ends a replay.
    if (this.player.playing && !this.player.stillAt(this.playAt())) this.stopPlay();
    const v = scrubberView(this.app.state.mode, this.shownSample(), this.app.state.generation);
    $('generation-section').hidden = v.hidden;
    const slider = $<HTMLInputElement>('generation');
    // The range first: a value past the old maximum would be clamped.
    slider.max = String(v.max);
    slider.value = String(v.value);
    slider.disabled = v.disabled;
    slider.title = v.title;
    $('generation-value').textContent = v.label;
    this.refreshPlayButton();
  }

  private refreshPlayButton(): void {
    const v = playButtonView(scrubberView(this.app.state.mode, this.shownSample(), this.app.state.generation), this.player.playing);
    const button = $<HTMLButtonElement>('generation-play');
    button.textContent = v.label;
    button.title = v.title;
    button.disabled = v.disabled;
  }

  /** Where the scrubber is, for the replay. */
  private playAt(): PlayAt {
    return { generation: this.app.state.generation, key: this.app.state.searchKey };
  }

  /** Play: replay the search from the scrubber's position (from the first generation at the end); Pause: stop where it is. */
  private togglePlay(): void {
    if (this.player.playing) {
      this.stopPlay();
      return;
    }
    if (this.app.state.mode !== 'sample' || !this.app.state.uri) return;
    const n = this.shownSample()?.generations ?? 0;
    const first = this.player.play(this.playAt(), n, performance.now());
    if (first === null) return;
    this.app.debug.playSteps = [];
    this.playStep(first, n);
  }

  /** Ask for the model of scrubber position `position` of a search of `generations` (the player has marked it asked). */
  private playStep(position: number, generations: number): void {
    this.app.state.setGeneration(position, generations);
    this.app.debug.playSteps.push({ position, askedAt: performance.now(), shownAt: null });
    // A final edit, sent at once: after the first step the last one's model is on screen, so nothing of this
    // page's is on its way; for the first, one on its way is for an older state.
    this.app.regrow();
  }

  /** A model is on screen (at `now`): during a replay, the next step after its wait, or the end. */
  playShown(r: PreviewResult, now: number): void {
    if (!this.player.playing) return;
    const model = r.sample && !isSearchResult(r.sample) ? r.sample.generation : null;
    const a = this.player.shown(model, this.playAt(), now);
    if (a.kind === 'wait') return;
    if (a.kind === 'next' || a.kind === 'done') {
      const step = this.app.debug.playSteps.at(-1);
      if (step) step.shownAt = now;
    }
    if (a.kind === 'next') {
      clearTimeout(this.playTimer);
      this.playTimer = setTimeout(() => {
        const position = this.player.advance(this.playAt(), performance.now());
        if (position === null) this.stopPlay();
        else this.playStep(position, this.player.generations);
      }, a.delayMs);
    } else {
      this.stopPlay();
    }
  }

  /** The replay ends (Pause, the end, a failure, the page moved): the scrubber stays at the generation shown or asked for. */
  stopPlay(): void {
    clearTimeout(this.playTimer);
    this.playTimer = undefined;
    this.player.stop();
    this.refreshPlayButton();
  }
}
