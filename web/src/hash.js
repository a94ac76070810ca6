// The view and time in the URL hash, so that a link reopens the same view:
// #t=12&eye=x,y,z&target=x,y,z&up=x,y,z&fov=50
// Numbers are written exactly (JS's shortest round-trip form): the renderer snaps splats to
// pixels, so even a 1e-7 change of the camera moves a few pixels.

/** The hash of a view and time step. */
export function encodeHash(view, timeStep) {
  const vec = (v) => v.join(",");
  return `#t=${timeStep}&eye=${vec(view.eye)}&target=${vec(view.target)}&up=${vec(view.up)}&fov=${view.vertical_fov_deg}`;
}

/** `{view, timeStep}` from a hash, or null when it does not hold a complete, finite view. */
export function decodeHash(hash) {
  const params = new URLSearchParams(hash.replace(/^#/, ""));
  const vec = (name) => {
    const parts = (params.get(name) || "").split(",").map(Number);
    return parts.length === 3 && parts.every(Number.isFinite) ? parts : null;
  };
  const eye = vec("eye"), target = vec("target"), up = vec("up");
  const fov = Number(params.get("fov"));
  const t = Number(params.get("t"));
  if (!eye || !target || !up || !Number.isFinite(fov) || !Number.isInteger(t) || t < 0) return null;
  return { view: { eye, target, up, vertical_fov_deg: fov }, timeStep: t };
}
