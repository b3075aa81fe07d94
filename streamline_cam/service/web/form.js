// The upload form: POST /jobs/upload, the service's one-line refusals shown by their field.

import { getJSON, request } from "./api.js";

/** Fields left out of the request when empty: the service's defaults apply. */
const OPTIONAL = new Set(["dialect", "closed", "planning_options"]);

function fillSelect(select, values, keepFirst = false) {
  const first = keepFirst ? select.firstElementChild : null;
  select.replaceChildren(...(first ? [first] : []));
  for (const value of values) {
    const option = document.createElement("option");
    option.value = option.textContent = value;
    select.append(option);
  }
}

/** Clear every message of the form. */
function clearErrors(form) {
  for (const p of form.querySelectorAll("[data-error-for]")) p.textContent = "";
  for (const el of form.querySelectorAll("[aria-invalid]")) el.removeAttribute("aria-invalid");
}

/** Show each message next to its field; what names no field of the form goes below it. */
function showErrors(form, error) {
  const general = [];
  for (const [field, message] of Object.entries(error.fields)) {
    // "planning_options.feed_mm_per_min" is shown by the planning options' field
    const name = form.elements[field] ? field : field.split(".")[0];
    const slot = form.querySelector(`[data-error-for="${CSS.escape(name)}"]`);
    if (slot && name) {
      slot.textContent = name === field ? message : `${field}: ${message}`;
      form.elements[name]?.setAttribute("aria-invalid", "true");
    } else {
      general.push(field ? `${field}: ${message}` : message);
    }
  }
  if (!Object.keys(error.fields).length) general.push(error.message);
  form.querySelector("#upload-error").textContent = general.join("; ");
}

/** Wire the form; `onQueued(job)` gets the accepted job's view. */
export async function setUpForm(form, onQueued) {
  const axis = form.elements.axis_mode;
  const fiveAxis = () => {
    for (const el of form.querySelectorAll(".five-axis")) {
      el.classList.toggle("inactive", axis.value === "3");
    }
  };
  axis.addEventListener("change", fiveAxis);
  fiveAxis();

  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    clearErrors(form);
    const data = new FormData(form);
    for (const name of OPTIONAL) {
      if (String(data.get(name) ?? "").trim() === "") data.delete(name);
    }
    const file = data.get("file");
    if (file instanceof File && file.size === 0 && file.name === "") data.delete("file");
    const button = form.querySelector("button[type=submit]");
    button.disabled = true;
    try {
      onQueued(await request("POST", "/jobs/upload", data));
    } catch (error) {  // a refusal (its fields), or no answer at all (the message)
      showErrors(form, { fields: error.fields || {}, message: error.message });
    } finally {
      button.disabled = false;
    }
  });

  const offer = await getJSON("/machines");
  fillSelect(form.elements.machine, offer.machines);
  if (offer.machines.includes("grbl-router")) form.elements.machine.value = "grbl-router";
  fillSelect(form.elements.dialect, offer.dialects, true);
}
