// Talking to the service: JSON requests, and its refusals as {field: message}.

/** A refused request: `fields` maps a form field ("scallop_mm", "planning_options.feed")
 *  to the service's one-line message; `message` is the whole answer in one line. */
export class ApiError extends Error {
  constructor(status, message, fields = {}) {
    super(message);
    this.status = status;
    this.fields = fields;
  }
}

/** The field a validation error's `loc` names: ["body", "scallop_mm"] -> "scallop_mm". */
function fieldOf(loc) {
  const parts = (loc || []).filter((p) => p !== "body" && typeof p === "string");
  return parts.join(".");
}

/** Turn an error answer's `detail` (a string, or FastAPI's list) into an ApiError. */
async function refusal(response) {
  let body = null;
  try {
    body = await response.json();
  } catch {
    return new ApiError(response.status, `${response.status} ${response.statusText}`);
  }
  const detail = body && body.detail;
  if (Array.isArray(detail)) {
    const fields = {};
    for (const item of detail) {
      const field = fieldOf(item.loc);
      if (!(field in fields)) fields[field] = item.msg;
    }
    const message = detail.map((d) => (fieldOf(d.loc) ? `${fieldOf(d.loc)}: ` : "") + d.msg)
      .join("; ");
    return new ApiError(response.status, message, fields);
  }
  return new ApiError(response.status, String(detail ?? response.statusText));
}

/** fetch() that answers the parsed JSON, or throws an ApiError naming the problem. */
export async function request(method, url, body) {
  const options = { method, headers: { Accept: "application/json" } };
  if (body instanceof FormData) {
    options.body = body;
  } else if (body !== undefined) {
    options.body = JSON.stringify(body);
    options.headers["Content-Type"] = "application/json";
  }
  const response = await fetch(url, options);
  if (!response.ok) throw await refusal(response);
  return response.status === 204 ? null : response.json();
}

export const getJSON = (url) => request("GET", url);
export const postJSON = (url, body) => request("POST", url, body);
