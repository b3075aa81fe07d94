// A finished job's results: the report's figures, its plots and the downloads.

const mm = (v) => `${v.toFixed(4)} mm`;
const mm2 = (v) => `${v.toFixed(1)} mm²`;
const seconds = (v) => (v >= 60 ? `${(v / 60).toFixed(1)} min` : `${v.toFixed(1)} s`);
const percent = (v) => `${(100 * v).toFixed(1)} %`;
const count = (v) => String(v);
const text = (v) => String(v);
const yesNo = (v) => (v ? "yes" : "no");
const length = (v) => `${v.toFixed(1)} mm`;

/** [stage, key path in the report, label, format]: the figures of the table. */
const FIGURES = [
  ["fit", "fit.method", "method", text],
  ["fit", "fit.n_sections", "sections", count],
  ["fit", "fit.points_per_section", "points per section", count],
  ["fit", "fit.closed", "closed sections", yesNo],
  ["fit", "fit.max_error_mm", "largest fit error", mm],
  ["fit", "fit.rms_error_mm", "RMS fit error", mm],
  ["fit", "fit.between_sections_mm", "error between sections", mm],
  ["fit", "fit.leave_one_out_mm", "leave-one-out error", mm],
  ["fit", "fit.tol_mm", "fit tolerance", mm],
  ["fit", "fit.within_tol", "within tolerance", yesNo],
  ["plan", "plan.planned_scallop_mm", "planned scallop", mm],
  ["plan", "plan.planned_chord_tol_mm", "planned chord deviation", mm],
  ["plan", "plan.length_mm", "path length", length],
  ["plan", "plan.cutting_length_mm", "cutting length", length],
  ["plan", "plan.unreachable_fraction", "unreachable surface", percent],
  ["plan", "plan.linking_reason", "linking", text],
  ["program", "program.lines", "lines", count],
  ["program", "program.linear_moves", "feed moves", count],
  ["program", "program.rapid_moves", "rapid moves", count],
  ["program", "program.time_s", "machining time", seconds],
  ["check", "check.errors", "check errors", count],
  ["check", "check.warnings", "check warnings", count],
  ["verified", "verify.max_gouge_mm", "deepest gouge", mm],
  ["verified", "verify.max_excess_mm", "most material left", mm],
  ["verified", "verify.max_scallop_mm", "highest scallop", mm],
  ["verified", "verify.requested_scallop_mm", "scallop asked for", mm],
  ["verified", "verify.stats.rms_mm", "RMS deviation", mm],
  ["verified", "verify.stats.cut_area_mm2", "area cut", mm2],
  ["verified", "verify.stats.uncut_area_mm2", "area not reached", mm2],
  ["verified", "verify.gouging_blocks.length", "gouging blocks (listed)", count],
  ["verified", "verify.unswept_moves", "moves not swept", count],
  ["verified", "verify.joints.max_mm", "joint interpolation error", mm],
];

/** Sentences of the report worth reading beside the table. */
const NOTES = ["placement.text", "fit.fairness.summary", "plan.blunt_face.text"];
const NOTE_LISTS = ["plan.advice", "check.issues"];

function at(report, path) {
  let value = report;
  for (const key of path.split(".")) {
    if (value === null || value === undefined) return undefined;
    value = value[key];
  }
  return value;
}

function cell(tag, content, className) {
  const node = document.createElement(tag);
  node.textContent = content;
  if (className) node.className = className;
  return node;
}

/** Fill the report table (figures the report lacks are left out) and its notes. */
export function showReport(table, notes, report) {
  const rows = [];
  for (const [stage, path, label, format] of FIGURES) {
    const value = at(report, path);
    if (value === undefined || value === null) continue;
    if (typeof value === "number" && !Number.isFinite(value)) continue;
    const row = document.createElement("tr");
    row.dataset.key = path;
    row.dataset.stage = stage;
    row.append(cell("td", stage, "stage"), cell("th", label), cell("td", format(value), "num"));
    rows.push(row);
  }
  const total = Object.values(report.seconds || {}).reduce((a, b) => a + b, 0);
  if (total > 0) {
    const row = document.createElement("tr");
    row.dataset.key = "seconds";
    row.append(cell("td", "job", "stage"), cell("th", "computing time"),
               cell("td", seconds(total), "num"));
    rows.push(row);
  }
  table.tBodies[0].replaceChildren(...rows);

  const items = [];
  for (const path of NOTES) {
    const value = at(report, path);
    if (value) items.push(cell("li", String(value)));
  }
  for (const path of NOTE_LISTS) {
    for (const value of at(report, path) || []) {
      items.push(cell("li", typeof value === "string" ? value : JSON.stringify(value)));
    }
  }
  notes.replaceChildren(...items);
}

/** The job's plots (its `plot:NAME` links) as images. */
export function showPlots(box, job) {
  const figures = [];
  for (const [name, url] of Object.entries(job.links || {})) {
    if (!name.startsWith("plot:")) continue;
    const figure = document.createElement("figure");
    const image = document.createElement("img");
    image.src = url;
    image.alt = `${name.slice(5)} plot of ${job.name}`;
    figure.dataset.plot = name.slice(5);
    figure.append(image, cell("figcaption", name.slice(5)));
    figures.push(figure);
  }
  box.replaceChildren(...figures);
}

const DOWNLOADS = [
  ["gcode", "G-code (.nc)"],
  ["toolpath", "toolpath (.npz)"],
  ["report", "report (.json)"],
  ["surface", "surface (.json)"],
  ["input", "sections (.csv)"],
  ["journal", "stream journal"],
];

/** Download links of the job's files that exist. */
export function showDownloads(box, job) {
  const links = [];
  for (const [name, label] of DOWNLOADS) {
    const url = job.links?.[name];
    if (!url) continue;
    const a = document.createElement("a");
    a.href = url;
    a.textContent = label;
    a.download = "";
    a.dataset.download = name;
    links.push(a);
  }
  box.replaceChildren(...links);
}
