// The machine panel: stream a finished job to a target and watch it; hold, resume, cancel.

import { getJSON, postJSON } from "./api.js";

const MOVING = new Set(["queued", "running", "held"]);
const AXES = ["x", "y", "z", "a", "b", "c"];

function eta(s) {
  if (s === null || s === undefined) return "–";
  const whole = Math.round(s);
  return whole >= 60 ? `${Math.floor(whole / 60)} min ${whole % 60} s` : `${whole} s`;
}

/** "X 1.000  Y 2.000  Z 3.000" from {x, y, z, ...} or [x, y, z, ...]. */
function position(p) {
  if (!p) return "–";
  const values = Array.isArray(p) ? Object.fromEntries(p.map((v, i) => [AXES[i], v])) : p;
  return AXES.filter((a) => typeof values[a] === "number")
    .map((a) => `${a.toUpperCase()} ${values[a].toFixed(3)}`).join("  ");
}

/** Whether `view` is an older view of the stream than `shown`.
 *
 * Answers to hold, resume and cancel and the `stream` events travel separately, so an answer
 * taken just before the stream became held can arrive after the event that says it is held.
 * A stream only moves forward (queued, then running or held, then its end), and between
 * running and held the service's `revision` orders its views. */
function isOlder(view, shown) {
  const ended = (s) => Boolean(s.state) && !MOVING.has(s.state);
  if (ended(shown)) return !ended(view);
  if (view.state === "queued" && shown.state !== "queued") return true;
  return Number.isInteger(view.revision) && Number.isInteger(shown.revision)
    && view.revision < shown.revision;
}

export class MachinePanel {
  constructor(root) {
    const $ = (id) => root.querySelector(`#${id}`);
    this.target = $("m-target");
    this.buttons = { stream: $("m-stream"), hold: $("m-hold"), resume: $("m-resume"),
                     cancel: $("m-cancel") };
    this.error = $("m-error");
    this.note = $("m-note");
    this.out = { state: $("m-state"), controller: $("m-controller"), position: $("m-position"),
                 line: $("m-line"), progress: $("m-progress"), percent: $("m-percent"),
                 eta: $("m-eta"), alarm: $("m-alarm") };
    this.root = root;
    this.job = null;
    this.stream = null;
    this.buttons.stream.addEventListener("click", () => this.act(
      () => postJSON(`/jobs/${this.job.id}/stream`, { target: this.target.value })));
    for (const verb of ["hold", "resume", "cancel"]) {
      this.buttons[verb].addEventListener("click", () => this.act(
        () => postJSON(`/jobs/${this.job.id}/streams/${this.stream.id}/${verb}`)));
    }
  }

  /** The targets on offer (GET /health) and whether streaming works here. */
  async load() {
    const health = await getJSON("/health");
    this.target.replaceChildren(...health.stream_targets.map((name) => {
      const option = document.createElement("option");
      option.value = option.textContent = name;
      return option;
    }));
    this.unavailable = health.streaming === "available" ? null : health.streaming;
    this.buttons_();
  }

  async act(call) {
    this.error.textContent = "";
    try {
      const answer = await call();
      if (answer && answer.job_id) this.update(answer);
    } catch (error) {
      this.error.textContent = error.message;
    }
  }

  /** The chosen job (its view, with its streams). */
  setJob(job) {
    if (this.job?.id !== job.id) {
      this.stream = null;
      this.error.textContent = "";
    }
    this.job = job;
    const streams = job.streams || [];
    if (streams.length) {
      const latest = streams[streams.length - 1];
      if (!this.stream || this.stream.id === latest.id || !MOVING.has(this.stream.state)) {
        this.update({ ...latest, ...(this.stream?.id === latest.id ? this.stream : {}) });
        return;
      }
    }
    this.render();
  }

  /** A stream's newest view (a `stream` event or an answer); others' streams are ignored. */
  update(stream) {
    if (!this.job || stream.job_id !== this.job.id) return;
    if (this.stream && this.stream.id !== stream.id && MOVING.has(this.stream.state)
        && !MOVING.has(stream.state)) return;  // an old stream's late news
    if (this.stream?.id === stream.id && isOlder(stream, this.stream)) return;
    this.stream = this.stream?.id === stream.id ? { ...this.stream, ...stream } : stream;
    this.render();
  }

  buttons_() {
    const state = this.stream?.state;
    const done = this.job?.state === "done";
    this.buttons.stream.disabled = !done || MOVING.has(state) || Boolean(this.unavailable);
    this.buttons.stream.title = this.unavailable || (done ? "" : "the job is not done");
    this.buttons.hold.disabled = state !== "running";
    this.buttons.resume.disabled = state !== "held";
    this.buttons.cancel.disabled = !MOVING.has(state);
  }

  render() {
    const s = this.stream;
    const o = this.out;
    this.root.dataset.streamState = s?.state || "";
    o.state.textContent = s?.state || "–";
    this.note.textContent = s?.error ? `${s.state}: ${s.error}` : "";
    o.controller.textContent = s?.controller_state || "–";
    o.position.textContent = position(s?.position_mm || s?.result?.final_position);
    o.line.textContent = s?.line != null ? `${s.line} of ${s.total_lines ?? "?"}` : "–";
    const pct = s?.percent ?? (s?.state === "done" ? 100 : null);
    o.progress.value = pct ?? 0;
    o.percent.textContent = pct != null ? `${pct.toFixed(1)} %` : "–";
    o.eta.textContent = MOVING.has(s?.state) ? eta(s?.eta_s) : "–";
    o.alarm.textContent = s?.alarm || s?.result?.alarm || "none";
    o.alarm.classList.toggle("error", Boolean(s?.alarm || s?.result?.alarm));
    this.buttons_();
  }
}
