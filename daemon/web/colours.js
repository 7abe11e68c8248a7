// The deviation colours of the dashboard, the same scale as the report's (planner/deviation_colours):
// against a nominal, relative to each point's tolerance (green inside, yellow and orange toward the
// upper limit, cyan and blue toward the lower, red outside); against the scan, a fixed ±0.1 mm scale
// with no red, since nothing fails against the scan. Grey: not measured.

export const SCAN_SCALE_MM = 0.1;
const STOPS = [[40, 80, 210], [0, 170, 205], [40, 170, 70], [235, 200, 0], [245, 120, 0]];
export const OUTSIDE = [215, 25, 35];
export const NOT_MEASURED = [150, 150, 150];

// Deviation over the limit on its side: 0 on the nominal, ±1 at a limit, beyond ±1 outside.
export function relative_deviation(deviation_mm, [lower, upper]) {
  const limit = deviation_mm >= 0 ? upper : -lower;
  if (limit > 0) return deviation_mm / limit;
  if (deviation_mm === 0) return 0;
  return deviation_mm >= 0 ? Infinity : -Infinity;
}

export function relative_colour(relative) {
  const t = (Math.min(1, Math.max(-1, relative)) + 1) * 2;
  const i = Math.min(3, Math.floor(t));
  const f = t - i;
  return STOPS[i].map((a, k) => Math.round(a + (STOPS[i + 1][k] - a) * f));
}

export function tolerance_colour(deviation_mm, zone) {
  if (deviation_mm > zone[1] || deviation_mm < zone[0]) return OUTSIDE;
  return relative_colour(relative_deviation(deviation_mm, zone));
}

export function scan_colour(deviation_mm) { return relative_colour(deviation_mm / SCAN_SCALE_MM); }

export const css = ([r, g, b]) => `rgb(${r}, ${g}, ${b})`;

// The colours of planned points by how they are measured.
export const METHOD_COLOURS = {two_touch: [31, 119, 180], faces: [23, 190, 207], none: [170, 170, 170]};
export const REASON_PALETTE = [[214, 39, 40], [148, 103, 189], [140, 86, 75], [227, 119, 194], [188, 189, 34], [255, 127, 14]];
// incomplete is a job's verdict only; a feature is pass, fail, undecided, not_measured or excluded.
export const VERDICT_COLOURS = {pass: STOPS[2], fail: OUTSIDE, undecided: STOPS[3], incomplete: [103, 58, 183],
                                not_measured: NOT_MEASURED, excluded: [215, 215, 215]};

// An edge point's deviation for colouring: against the nominal (its `inspection`) when the result
// has one (null for a point the nominal did not judge), else against the scan.
export function edge_deviation(point, inspected) {
  if (point.status !== 'measured') return null;
  if (inspected) {
    const n = point.inspection;
    if (!n || n.deviation_mm === null || n.deviation_mm === undefined || n.verdict === 'not_measured' || n.verdict === 'excluded') return null;
    return {value: n.deviation_mm, colour: tolerance_colour(n.deviation_mm, n.tolerance_mm), nominal: true};
  }
  if (point.deviation_mm === null || point.deviation_mm === undefined) return null;
  return {value: point.deviation_mm, colour: scan_colour(point.deviation_mm), nominal: false};
}
