// Sends the newest value of something the user is dragging (a slider, a colour) without piling up
// requests: one request in flight, at most one every `intervalMs`, and patches made meanwhile are
// merged so the last state always reaches the server.

export class PatchSender {
  constructor(send, intervalMs = 80) {
    this.sendFn = send;          // async (patch) => answer
    this.intervalMs = intervalMs;
    this.patch = null;
    this.inFlight = false;
    this.timer = 0;
    this.last = 0;
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

  get busy() {
    return this.inFlight || this.patch !== null;
  }

  schedule() {
    if (this.inFlight || this.timer || !this.patch) return;
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
    this.inFlight = true;
    this.last = performance.now();
    let answer;
    let failure = null;
    try {
      answer = await this.sendFn(patch);
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
