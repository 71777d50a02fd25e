// At most one request in flight; edits made meanwhile are merged into one
// follow-up request with the latest state. Dragging a slider or a control
// point thus never queues a backlog of stale models, and the newest edit
// always wins. Every result is delivered (they arrive in order, because only
// one request is in flight), marked `final` when no newer edit is pending,
// so a long drag still shows intermediate models.

export interface Delivery<R> {
  result: R;
  /** `performance.now()`-style time of the oldest edit this result answers. */
  editedAt: number;
  /** No newer edit is waiting: this is the model for the current state. */
  final: boolean;
}

export class Coalescer<S, R> {
  private inFlight = false;
  private dirty = false;
  private firstDirtyAt = 0;
  private disposed = false;

  constructor(
    private readonly state: () => S,
    private readonly send: (state: S) => Promise<R>,
    private readonly deliver: (d: Delivery<R>) => void,
    private readonly fail: (e: unknown) => void,
    private readonly now: () => number = () => Date.now(),
  ) {}

  /** Something changed: make sure a request with the new state follows. */
  trigger(editedAt: number = this.now()): void {
    if (this.disposed) return;
    if (!this.dirty) this.firstDirtyAt = editedAt;
    this.dirty = true;
    if (!this.inFlight) void this.pump();
  }

  get busy(): boolean {
    return this.inFlight || this.dirty;
  }

  /** An edit is waiting for its request (a newer state than any in flight). */
  get pending(): boolean {
    return this.dirty;
  }

  dispose(): void {
    this.disposed = true;
  }

  private async pump(): Promise<void> {
    while (this.dirty && !this.disposed) {
      this.dirty = false;
      const editedAt = this.firstDirtyAt;
      this.inFlight = true;
      try {
        const result = await this.send(this.state());
        if (!this.disposed) this.deliver({ result, editedAt, final: !this.dirty });
      } catch (e) {
        // A failure for a state that is already outdated is not worth showing.
        if (!this.dirty && !this.disposed) this.fail(e);
      } finally {
        this.inFlight = false;
      }
    }
  }
}
