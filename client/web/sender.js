// Sends the newest value of something the user is dragging (a slider, a colour) without piling up
// requests: one request in flight, at most one every `intervalMs`, and patches made meanwhile are
// merged so the last state always reaches the server. end() (the control released) sends the last
// state once more, at once, saying the interaction ended: the stream's still then needs no
// settle time (X-Myriad-Interaction: end, protocol/reference.md).

export class PatchSender {
  constructor(send, intervalMs = 80) {
    this.sendFn = send;          // async (patch) => answer
    this.intervalMs = intervalMs;
    this.patch = null;
    this.inFlight = false;
    this.timer = 0;
    this.last = 0;
    this.lastPatch = null;       // the last patch sent (end() sends it again)
    this.ending = false;         // the next request says the interaction ended
    this.onAnswer = () => {};    // (answer), after the last queued patch landed
    this.onProblem = () => {};   // (ApiError)
  }

  // Merges one level deep, so {sun: {color}} and {sun: {intensity}} both survive.
  queue(patch) {
    const merged = {...(this.patch || {})};
    for (const [key, value] of Object.entries(patch)) {
      const isObject = value && typeof value === 'object' && !Array.isArray(value);
      merged[key] = isObject ? {...(merged[key] || {}), ...value} : value;
    }
    this.patch = merged;
    this.schedule();
  }

  end() {
    if (!this.patch) this.patch = this.lastPatch;
    if (!this.patch) return;
    this.ending = true;
    this.schedule();
  }

  get busy() {
    return this.inFlight || this.patch !== null;
  }

  // Forgets a patch not sent yet (the server's state replaced what it would change).
  drop() {
    this.patch = null;
  }

  schedule() {
    if (this.inFlight || !this.patch) return;
    if (this.timer) {
      if (!this.ending) return;
      clearTimeout(this.timer);  // the interaction's end goes now
      this.timer = 0;
    }
    if (this.ending) {
      this.flush();  // at once, from the release itself: a zero timer waits behind other tasks
      return;
    }
    const wait = Math.max(0, this.last + this.intervalMs - performance.now());
    this.timer = setTimeout(() => {
      this.timer = 0;
      this.flush();
    }, wait);
  }

  async flush() {
    const patch = this.patch;
    if (!patch) return;
    this.patch = null;
    this.lastPatch = patch;
    const end = this.ending;
    this.ending = false;
    this.inFlight = true;
    this.last = performance.now();
    let answer;
    let failure = null;
    try {
      answer = await this.sendFn(patch, end);
    } catch (e) {
      failure = e;
    }
    // No longer busy before the answer is shown: the controls take the server's values now,
    // unless a newer patch is already waiting (then its answer will).
    this.inFlight = false;
    if (failure) this.onProblem(failure);
    else if (!this.patch) this.onAnswer(answer);
    this.schedule();
  }
}
