// Requests for the model of the page's state, without a backlog and without
// waiting for stale answers.
//
// Continuous edits (the moves of a drag, a slider being dragged) are
// coalesced: one request in flight, and the edits made meanwhile are merged
// into one follow-up request with the latest state, sent when the answer
// comes. A long drag thus shows intermediate models and never queues stale
// ones.
//
// A final edit (a release, a typed value, a click: `trigger(t, true)` or
// `flush()`) does not wait for a stale answer: if a request is in flight
// for an older state, the newest state is sent at once. The host supersedes
// the older request (the language server answers it with ServerCancelled,
// docs/lsp-extensions.md), and its answer, whatever it is, is dropped
// without being shown: after a request is sent, no answer to an older one
// is delivered or reported. At most two requests are in flight (the stale
// one and the current one); a final edit made while two are in flight is
// sent when one of them answers.
//
// Sent a few milliseconds apart, the two may reach the host in the other
// order (`grmc view` takes each HTTP connection in a thread of its own).
// The page numbers its live requests (`client`, `order`: main.ts), and the
// language server never lets a client's older live request supersede a
// later one, whatever order they arrive in (docs/lsp-extensions.md): the
// stale one is answered "superseded" at once. For a host that does not
// order them, the coalescer still checks: when the current request is
// answered "superseded" while the stale one is still in flight, or after
// the host built the stale one to the end (so it was not the one
// superseded), it sends the current state once more; otherwise the page
// would be left with no model for its state.

export interface Delivery<R> {
  result: R;
  /** `performance.now()`-style time of the oldest edit this result answers. */
  editedAt: number;
  /** No newer edit is waiting: this is the model for the current state. */
  final: boolean;
}

/** Most requests in flight at once: one stale, one current. */
export const MAX_IN_FLIGHT = 2;

export interface CoalescerOptions {
  /** Whether a failure says the host dropped the request on purpose (superseded or cancelled): never reported. */
  isSuperseded?: (e: unknown) => boolean;
  /** The newest request was superseded by someone else (no newer request of this coalescer follows it). */
  supersededElsewhere?: () => void;
}

export class Coalescer<S, R> {
  private inFlight = 0;
  /** Number of the last request sent (1, 2, ...). */
  private sent = 0;
  private dirty = false;
  /** The edit waiting is final: send it even while a request is in flight. */
  private urgent = false;
  private firstDirtyAt = 0;
  private disposed = false;
  /** Answers dropped because a newer request had been sent (results and errors alike). */
  staleAnswers = 0;
  /** Of those and the others, answers that were the host's "superseded" or "cancelled" error. */
  supersededAnswers = 0;
  /** Requests sent while another was in flight (each supersedes it). */
  supersedes = 0;
  /** Current requests sent again after this coalescer's own stale request reached the host after them and superseded them. */
  resends = 0;
  /** Since the last request went, an older one was answered with something other than "superseded" (the host built it to the end). */
  private olderFinished = false;
  /** The current state was sent again once already (reset by the next edit): never more. */
  private resent = false;

  constructor(
    private readonly state: () => S,
    private readonly send: (state: S) => Promise<R>,
    private readonly deliver: (d: Delivery<R>) => void,
    private readonly fail: (e: unknown) => void,
    private readonly now: () => number = () => Date.now(),
    private readonly options: CoalescerOptions = {},
  ) {}

  /**
   * Something changed: make sure a request with the new state follows. A
   * `final` edit is sent at once even if a request for an older state is in
   * flight; other edits wait for its answer.
   */
  trigger(editedAt: number = this.now(), final = false): void {
    if (this.disposed) return;
    if (!this.dirty) this.firstDirtyAt = editedAt;
    this.dirty = true;
    this.resent = false;
    if (final) this.urgent = true;
    this.pump();
  }

  /**
   * A gesture ended (pointer or slider released) without changing the state
   * again: edits still waiting are sent at once instead of after the stale
   * answer. Nothing is sent when no edit waits.
   */
  flush(): void {
    if (this.disposed || !this.dirty) return;
    this.urgent = true;
    this.pump();
  }

  /** A request is in flight or an edit waits for one. */
  get busy(): boolean {
    return this.inFlight > 0 || this.dirty;
  }

  /** An edit is waiting for its request (a newer state than any in flight). */
  get pending(): boolean {
    return this.dirty;
  }

  /** Requests sent and not answered yet (at most {@link MAX_IN_FLIGHT}). */
  get inFlightCount(): number {
    return this.inFlight;
  }

  dispose(): void {
    this.disposed = true;
  }

  private pump(): void {
    while (this.dirty && !this.disposed && (this.inFlight === 0 || (this.urgent && this.inFlight < MAX_IN_FLIGHT))) {
      if (this.inFlight > 0) this.supersedes++;
      this.dirty = false;
      this.urgent = false;
      this.inFlight++;
      this.olderFinished = false;
      const seq = ++this.sent;
      const editedAt = this.firstDirtyAt;
      let request: Promise<R>;
      try {
        request = this.send(this.state());
      } catch (e) {
        request = Promise.reject(e);
      }
      request.then(
        (result) => this.settled(seq, () => this.deliver({ result, editedAt, final: !this.dirty })),
        (e: unknown) => this.settled(seq, () => this.failed(e), e, editedAt),
      );
    }
  }

  private settled(seq: number, use: () => void, error?: unknown, editedAt = 0): void {
    this.inFlight--;
    if (this.disposed) return;
    const superseded = error !== undefined && (this.options.isSuperseded?.(error) ?? false);
    if (superseded) this.supersededAnswers++;
    if (seq < this.sent) {
      // A newer request was sent: this answer is stale, whatever it says.
      this.staleAnswers++;
      if (!superseded) this.olderFinished = true;
    } else if (superseded && !this.dirty && !this.resent && (this.inFlight > 0 || this.olderFinished)) {
      // Likely superseded by this coalescer's own older request, which reached the host after it: the current
      // state again (it goes after the older one), once.
      this.resent = true;
      this.resends++;
      this.dirty = true;
      this.urgent = true;
      this.firstDirtyAt = editedAt;
    } else if (superseded) {
      // Superseded by someone else's request: nothing to show or report.
      if (!this.dirty) this.options.supersededElsewhere?.();
    } else {
      try {
        use();
      } catch (e) {
        this.failed(e);
      }
    }
    this.pump();
  }

  private failed(e: unknown): void {
    // A failure for a state that is already outdated is not worth showing.
    if (!this.dirty) this.fail(e);
  }
}

/**
 * A request for the same thing as the one still on its way is that request:
 * its answer is shared, nothing is sent again. The page reads its state
 * when a request goes, so a release right after the move that sent it (a
 * scrubber or slider moved and let go in one task) asks for what the
 * request in flight asks for already. Sent twice, the two would race to the
 * host, which may take them in either order (`grmc view` answers each
 * connection in a thread of its own): the later to arrive supersedes the
 * other, and if that is the older one, the only model built answers a
 * request the coalescer counts as stale, and nothing would be shown.
 */
export class SharedRequest<R> {
  private current: { key: string; answer: Promise<R> } | null = null;

  /** `send()`'s answer, or the answer of the request in flight for the same `key`. */
  run(key: string, send: () => Promise<R>): Promise<R> {
    if (this.current?.key === key) return this.current.answer;
    let answer: Promise<R>;
    try {
      answer = send();
    } catch (e) {
      answer = Promise.reject(e);
    }
    const entry = { key, answer };
    this.current = entry;
    const done = () => {
      if (this.current === entry) this.current = null;
    };
    answer.then(done, done);
    return answer;
  }

  /**
   * The host's side changed (another document shown, the document edited,
   * the server restarted): the next request is sent even for the same
   * key, since the answer on its way may be of the old state (or never come).
   */
  forget(): void {
    this.current = null;
  }
}
