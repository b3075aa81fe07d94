// The page: the parts wired together and fed by the service's live events (GET /events).

import { getJSON } from "./api.js";
import { setUpForm } from "./form.js";
import { JobsList } from "./jobs.js";
import { MachinePanel } from "./machine.js";
import { MAX_POINTS, Preview } from "./preview.js";
import { showDownloads, showPlots, showReport } from "./results.js";

const $ = (id) => document.getElementById(id);

let preview = null;  // made when a finished job is first shown (WebGL only when needed)
let shown = { id: null, state: null };  // what the results panels show

const machine = new MachinePanel($("machine-panel"));
const jobs = new JobsList($("jobs"), $("no-jobs"), $("counts"), {
  onSelect: showJob,
  onError: (message) => { $("upload-error").textContent = message; },
});

function describe(job) {
  const parts = [job.state];
  if (job.state === "running" && job.stage) {
    parts.push(`${job.stage} ${Math.round(100 * (job.progress[job.stage] || 0))}%`);
  }
  if (job.attempts > 1) parts.push(`attempt ${job.attempts}`);
  const p = job.parameters || {};
  if (p.cutter) {
    parts.push(`${p.machine}, ${p.cutter}, scallop ${p.scallop_mm} mm, chord ${p.chord_tol_mm} mm, `
               + `${p.axis_mode === "3" ? "3-axis" : `5-axis lead ${p.lead_deg}° tilt ${p.tilt_deg}°`}, `
               + `${p.linking} linking`);
  }
  return parts.join(" · ");
}

/** Show a job; results are fetched once it is done (and again when another is chosen). */
function showJob(job, chosen) {
  $("pick").hidden = true;
  $("job").hidden = false;
  $("job").dataset.job = job.id;
  $("job").dataset.state = job.state;
  $("job-title").textContent = job.name;
  $("job-status").textContent = describe(job);
  $("job-error").textContent = job.error || "";
  showDownloads($("downloads"), job);
  machine.setJob(job);
  if (chosen) {  // the list's views carry no streams: the job's own view has them, live
    getJSON(`/jobs/${job.id}`).then((full) => {
      if (jobs.selected === full.id && full.streams.length) jobs.update(full);
    }).catch(() => {});  // gone meanwhile: the list says so
  }
  const done = job.state === "done";
  for (const id of ["preview-panel", "report-panel", "plots-panel"]) $(id).hidden = !done;
  if (!chosen && shown.id === job.id && shown.state === job.state) return;
  shown = { id: job.id, state: job.state };
  preview?.clear();  // not the last job's view while this one's loads
  $("preview-info").textContent = "";
  if (!done) return;
  showPlots($("plots"), job);
  loadResults(job).catch((error) => {
    $("job-error").textContent = `results: ${error.message}`;
  });
}

async function loadResults(job) {
  const [report, data] = await Promise.all([
    getJSON(`/jobs/${job.id}/report`),
    getJSON(`/jobs/${job.id}/preview?max_points=${MAX_POINTS}`).catch((error) => error),
  ]);
  if (shown.id !== job.id) return;  // another job was chosen meanwhile
  showReport($("report"), $("report-notes"), report);
  if (data instanceof Error) {
    $("preview-info").textContent = `(not available: ${data.message})`;
    return;
  }
  preview ??= new Preview($("viewport"), $("tool-slider"), $("tool-readout"));
  const drawn = preview.show(job, data);
  const decimated = data.source_points && data.source_points > drawn.points
    ? `, ${data.source_points} in the toolpath` : "";
  $("preview-info").textContent = `(${drawn.passes} passes, ${drawn.points} points shown`
    + `${decimated})`;
}

/** Where the 3-D view puts the machine's tool: the live position of a moving stream on
 *  a 3-axis machine (its program coordinates are the preview's); else nowhere. */
function liveTool(stream) {
  const p = stream.position_mm;
  const moving = ["queued", "running", "held"].includes(stream.state);
  const linear = p && Object.keys(p).every((axis) => "xyz".includes(axis));
  return moving && linear ? p : null;
}

/** Live updates: a `job` event per job on connect and on each change, `stream` events. */
function listen() {
  const live = $("live");
  const events = new EventSource("/events");
  events.addEventListener("open", () => {
    live.textContent = "live";
    live.className = "live on";
  });
  events.addEventListener("error", () => {
    live.textContent = "reconnecting…";
    live.className = "live off";
  });
  events.addEventListener("job", (event) => jobs.update(JSON.parse(event.data)));
  events.addEventListener("stream", (event) => {
    const stream = JSON.parse(event.data);
    machine.update(stream);
    if (stream.job_id === shown.id) preview?.showMachine(liveTool(stream));
    const job = jobs.jobs.get(stream.job_id);
    if (job) {
      const others = (job.streams || []).filter((s) => s.id !== stream.id);
      job.streams = [...others, stream];
    }
  });
}

async function start() {
  const queued = (job) => {
    jobs.update(job);
    jobs.select(job.id);
  };
  await Promise.all([
    setUpForm($("upload"), queued),
    machine.load(),
    getJSON("/jobs?limit=100").then((list) => {
      for (const job of list.jobs.slice().reverse()) jobs.update(job);
    }),
  ]);
  listen();
  document.body.dataset.ready = "true";
}

start().catch((error) => {
  $("upload-error").textContent = `the page could not start: ${error.message}`;
});
