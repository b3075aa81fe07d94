// The jobs list: state and progress by stage, updated from the service's events.

import { postJSON } from "./api.js";

const ACTIVE = new Set(["queued", "running"]);

function el(tag, props = {}, ...children) {
  const node = Object.assign(document.createElement(tag), props);
  node.append(...children);
  return node;
}

/** Progress bars, one per stage (fit, plan, post, check, verify). */
function stageBars(job) {
  const box = el("div", { className: "stages" });
  for (const [stage, fraction] of Object.entries(job.progress || {})) {
    const percent = Math.round(100 * fraction);
    const bar = el("div", { className: "stage", title: `${stage}: ${percent}%` },
      el("span", { className: "stage-name", textContent: stage }),
      el("progress", { max: 100, value: percent }));
    bar.dataset.stage = stage;
    if (job.stage === stage && job.state === "running") bar.classList.add("current");
    box.append(bar);
  }
  return box;
}

export class JobsList {
  /** `table`: the jobs table; `onSelect(job)` when a row is chosen; `onError(message)`. */
  constructor(table, empty, counts, { onSelect, onError }) {
    this.body = table.tBodies[0];
    this.empty = empty;
    this.counts = counts;
    this.onSelect = onSelect;
    this.onError = onError;
    this.jobs = new Map();
    this.selected = null;
  }

  /** A job's newest view (from GET /jobs, an upload's answer or a `job` event). */
  update(job) {
    const known = this.jobs.get(job.id);
    if (known && known.streams?.length && !job.streams?.length) job.streams = known.streams;
    this.jobs.set(job.id, job);
    const row = this.row(job);
    const old = this.body.querySelector(`tr[data-job="${job.id}"]`);
    if (old) {
      old.replaceWith(row);
    } else {  // newest first, whatever order the views arrive in
      const later = [...this.body.rows].find(
        (tr) => this.jobs.get(tr.dataset.job).created < job.created);
      this.body.insertBefore(row, later || null);
    }
    this.empty.hidden = this.jobs.size > 0;
    this.showCounts();
    if (this.selected === job.id) this.onSelect(job, false);
  }

  showCounts() {
    const counts = {};
    for (const job of this.jobs.values()) counts[job.state] = (counts[job.state] || 0) + 1;
    this.counts.textContent = Object.entries(counts).map(([s, n]) => `${n} ${s}`).join(", ");
  }

  row(job) {
    const cancel = el("button", { type: "button", className: "small cancel",
      textContent: "Cancel", title: "cancel this job" });
    cancel.hidden = !ACTIVE.has(job.state);
    cancel.addEventListener("click", async (event) => {
      event.stopPropagation();
      cancel.disabled = true;
      try {
        this.update(await postJSON(`/jobs/${job.id}/cancel`));
      } catch (error) {
        cancel.disabled = false;
        this.onError(error.message);
      }
    });
    const created = new Date(job.created);
    const row = el("tr", {},
      el("td", {}, el("div", { className: "job-name", textContent: job.name }),
        el("small", { className: "muted", textContent: created.toLocaleTimeString() })),
      el("td", {}, el("span", { className: `badge ${job.state}`, textContent: job.state })),
      el("td", {}, stageBars(job)),
      el("td", {}, cancel));
    row.dataset.job = job.id;
    row.dataset.state = job.state;
    row.tabIndex = 0;
    if (job.id === this.selected) row.classList.add("selected");
    const choose = () => this.select(job.id);
    row.addEventListener("click", choose);
    row.addEventListener("keydown", (e) => { if (e.key === "Enter") choose(); });
    return row;
  }

  select(id) {
    this.selected = id;
    for (const tr of this.body.rows) tr.classList.toggle("selected", tr.dataset.job === id);
    const job = this.jobs.get(id);
    if (job) this.onSelect(job, true);
  }
}
