// The coalescer's final edits: sent at once while a stale request is in
// flight (which the host supersedes), the stale answer dropped without being
// shown or reported, never more than one stale and one current request; a
// current request the stale one superseded (reaching the host after it) is
// sent again, once.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { Coalescer, type Delivery, SharedRequest } from '../preview/src/coalesce.js';
import { REQUEST_CANCELLED, SERVER_CANCELLED } from '../preview/src/messages.js';
import { TransportError, isSuperseded } from '../preview/src/transport.js';

/** A coalescer over a numeric state whose requests the test answers by hand. */
function harness() {
  let state = 0;
  let clock = 0;
  const sent: number[] = [];
  const answers: Array<{ resolve: (r: number) => void; reject: (e: unknown) => void }> = [];
  const delivered: Array<Delivery<number>> = [];
  const failures: string[] = [];
  let elsewhere = 0;
  const c = new Coalescer<number, number>(
    () => state,
    (s) => {
      sent.push(s);
      return new Promise<number>((resolve, reject) => answers.push({ resolve, reject }));
    },
    (d) => delivered.push(d),
    (e) => failures.push((e as Error).message),
    () => clock,
    { isSuperseded, supersededElsewhere: () => elsewhere++ },
  );
  return {
    c,
    sent,
    answers,
    delivered,
    failures,
    elsewhere: () => elsewhere,
    edit(s: number, at: number, final = false) {
      state = s;
      clock = at;
      c.trigger(at, final);
    },
  };
}

const settle = () => new Promise((r) => setImmediate(r));
const superseded = () => new TransportError('superseded by a newer grm/preview request for this document', SERVER_CANCELLED);

test('coalescer: moves wait for the answer in flight; a final edit is sent at once and the stale answer is never shown', async () => {
  const h = harness();
  h.edit(1, 10); // the drag's first move: sent
  h.edit(2, 20); // later moves wait for its answer...
  h.edit(3, 30);
  assert.deepEqual(h.sent, [1]);
  assert.equal(h.c.inFlightCount, 1);
  h.c.flush(); // ...until the release: the newest state goes out now
  assert.deepEqual(h.sent, [1, 3]);
  assert.equal(h.c.inFlightCount, 2);
  assert.equal(h.c.supersedes, 1);
  // The host supersedes the stale request; its error is not a failure.
  h.answers[0].reject(superseded());
  await settle();
  assert.equal(h.delivered.length, 0);
  assert.equal(h.failures.length, 0);
  h.answers[1].resolve(30);
  await settle();
  assert.deepEqual(h.delivered, [{ result: 30, editedAt: 20, final: true }]);
  assert.equal(h.c.staleAnswers, 1);
  assert.equal(h.c.supersededAnswers, 1);
  assert.equal(h.c.busy, false);
});

test('coalescer: a stale answer that is a model, early or late, is dropped too', async () => {
  const h = harness();
  h.edit(1, 10);
  h.edit(2, 20, true); // a final edit (a typed value) while 1 is in flight
  assert.deepEqual(h.sent, [1, 2]);
  // A host that finished the stale model before the newer request came.
  h.answers[0].resolve(10);
  await settle();
  assert.equal(h.delivered.length, 0, 'the stale model is not shown');
  h.answers[1].resolve(20);
  await settle();
  assert.deepEqual(
    h.delivered.map((d) => d.result),
    [20],
  );
  // The other order: the newer answer first, the stale one after it.
  h.edit(3, 30);
  h.edit(4, 40, true);
  h.answers[3].resolve(40);
  await settle();
  h.answers[2].resolve(30);
  await settle();
  assert.deepEqual(
    h.delivered.map((d) => d.result),
    [20, 40],
    'an older model never replaces a newer one',
  );
  assert.equal(h.c.staleAnswers, 2);
});

test('coalescer: a final edit that changes nothing new does not resend; flush without waiting edits is a no-op', async () => {
  const h = harness();
  h.c.flush();
  assert.deepEqual(h.sent, []);
  h.edit(1, 10);
  h.c.flush(); // released where the move in flight left it
  assert.deepEqual(h.sent, [1], 'the request in flight is for the current state');
  h.answers[0].resolve(10);
  await settle();
  assert.deepEqual(h.delivered, [{ result: 10, editedAt: 10, final: true }]);
});

test('coalescer: at most one stale and one current request in flight', async () => {
  const h = harness();
  h.edit(1, 10);
  h.edit(2, 20, true);
  h.edit(3, 30, true);
  h.edit(4, 40, true);
  assert.deepEqual(h.sent, [1, 2], 'two in flight: the third waits');
  assert.equal(h.c.inFlightCount, 2);
  assert.equal(h.c.pending, true);
  h.answers[0].reject(superseded());
  await settle();
  assert.deepEqual(h.sent, [1, 2, 4], 'one answered: the newest state goes out at once, superseding 2');
  h.answers[1].reject(superseded());
  h.answers[2].resolve(40);
  await settle();
  assert.deepEqual(
    h.delivered.map((d) => [d.result, d.final]),
    [[40, true]],
  );
  assert.deepEqual(h.failures, []);
  assert.equal(h.c.supersedes, 2);
  assert.equal(h.c.busy, false);
});

test('coalescer: moves after a superseding request wait for the current answer, which is then not final', async () => {
  const h = harness();
  h.edit(1, 10);
  h.edit(2, 20, true);
  h.edit(3, 30); // a new drag starts while two are in flight
  h.answers[0].reject(superseded());
  await settle();
  assert.deepEqual(h.sent, [1, 2], 'a move does not supersede');
  h.answers[1].resolve(20);
  await settle();
  assert.deepEqual(h.delivered, [{ result: 20, editedAt: 20, final: false }]);
  assert.deepEqual(h.sent, [1, 2, 3]);
});

test('coalescer: real failures of the current request are reported; a request superseded by someone else is not', async () => {
  const h = harness();
  h.edit(1, 10);
  h.answers[0].reject(new TransportError('the program has 1 error: fix it to preview', -32803));
  await settle();
  assert.deepEqual(h.failures, ['the program has 1 error: fix it to preview']);
  // Another client's newer request (another page on the same document).
  h.edit(2, 20);
  h.answers[1].reject(superseded());
  await settle();
  // Or the host cancelled it.
  h.edit(3, 30);
  h.answers[2].reject(new TransportError('cancelled', REQUEST_CANCELLED));
  await settle();
  assert.equal(h.failures.length, 1);
  assert.equal(h.elsewhere(), 2);
  assert.equal(h.c.staleAnswers, 0);
  assert.equal(h.c.supersededAnswers, 2);
  assert.equal(h.c.busy, false);
});

test('coalescer: a current request its own stale request superseded (they reached the host in the other order) is sent again, once', async () => {
  // The stale request still in flight when the current one is answered "superseded".
  const h = harness();
  h.edit(1, 10);
  h.edit(2, 20, true);
  assert.deepEqual(h.sent, [1, 2]);
  h.answers[1].reject(superseded());
  await settle();
  assert.deepEqual(h.sent, [1, 2, 2], 'the current state again, after the stale request');
  assert.equal(h.c.resends, 1);
  h.answers[0].reject(superseded()); // the resend superseded the stale one in turn
  h.answers[2].resolve(20);
  await settle();
  assert.deepEqual(h.delivered, [{ result: 20, editedAt: 20, final: true }]);
  assert.deepEqual([h.failures, h.elsewhere(), h.c.busy], [[], 0, false]);

  // The stale request built to the end and answered first: it was not superseded, so it superseded the current one.
  const k = harness();
  k.edit(1, 10);
  k.edit(2, 20, true);
  k.answers[0].resolve(10);
  await settle();
  k.answers[1].reject(superseded());
  await settle();
  assert.deepEqual(k.sent, [1, 2, 2]);
  // Superseded again (by someone else this time): not sent a third time.
  k.answers[2].reject(superseded());
  await settle();
  assert.deepEqual(k.sent, [1, 2, 2]);
  assert.deepEqual([k.delivered, k.failures, k.elsewhere(), k.c.resends, k.c.busy], [[], [], 1, 1, false]);
  // The next edit may be sent again once more.
  k.edit(3, 30, true);
  k.edit(4, 40, true);
  k.answers[4].reject(superseded());
  await settle();
  assert.deepEqual(k.sent, [1, 2, 2, 3, 4, 4]);
});

test('coalescer: the stale request superseded by the current one, which someone else supersedes: not sent again', async () => {
  const h = harness();
  h.edit(1, 10);
  h.edit(2, 20, true);
  h.answers[0].reject(superseded());
  await settle();
  h.answers[1].reject(superseded());
  await settle();
  assert.deepEqual(h.sent, [1, 2]);
  assert.deepEqual([h.c.resends, h.elsewhere(), h.c.busy], [0, 1, false]);
});

test('superseded errors are recognised by their code only', () => {
  assert.equal(isSuperseded(new TransportError('x', SERVER_CANCELLED)), true);
  assert.equal(isSuperseded(new TransportError('x', REQUEST_CANCELLED)), true);
  assert.equal(isSuperseded(new TransportError('superseded', -32801)), false, 'ContentModified is another matter');
  assert.equal(isSuperseded(new TransportError('superseded')), false);
  assert.equal(isSuperseded(new Error('superseded')), false);
});

test('shared request: a request for the key on its way shares its answer; once answered, or forgotten, it is sent again', async () => {
  const shared = new SharedRequest<string>();
  const sent: string[] = [];
  const pending: Array<{ resolve: (r: string) => void; reject: (e: unknown) => void }> = [];
  const send = (key: string) => () => {
    sent.push(key);
    return new Promise<string>((resolve, reject) => pending.push({ resolve, reject }));
  };
  const a1 = shared.run('a', send('a'));
  const a2 = shared.run('a', send('a'));
  assert.equal(a2, a1, 'the same answer');
  assert.deepEqual(sent, ['a']);
  // Another key is another request, and the one on its way from then on.
  const b = shared.run('b', send('b'));
  assert.deepEqual(sent, ['a', 'b']);
  const a3 = shared.run('a', send('a'));
  assert.notEqual(a3, a1);
  assert.deepEqual(sent, ['a', 'b', 'a']);
  pending[0].resolve('A1');
  pending[1].resolve('B');
  pending[2].resolve('A3');
  assert.deepEqual(await Promise.all([a1, a2, b, a3]), ['A1', 'A1', 'B', 'A3']);
  // Answered: the next request for the key goes.
  void shared.run('a', send('a'));
  assert.equal(sent.length, 4);
  // A failure is shared too, and the key is free again after it.
  const f1 = shared.run('f', send('f'));
  const f2 = shared.run('f', send('f'));
  pending[4].reject(new Error('refused'));
  await assert.rejects(f1, /refused/);
  await assert.rejects(f2, /refused/);
  void shared.run('f', send('f'));
  assert.deepEqual(sent.slice(4), ['f', 'f']);
  // Forgotten (the host changed): sent again though one is on its way.
  shared.forget();
  void shared.run('f', send('f'));
  assert.deepEqual(sent.slice(4), ['f', 'f', 'f']);
  // A send that throws is a failed answer, not an exception of run.
  await assert.rejects(
    shared.run('t', () => {
      throw new Error('no host');
    }),
    /no host/,
  );
  void shared.run('t', send('t'));
  assert.equal(sent[sent.length - 1], 't');
  for (const p of pending.slice(5)) p.resolve('');
});
