// The histogram of a finished job's edge-point deviations (Chart.js 3, Debian's libjs-chart.js,
// loaded as a classic script: window.Chart), each bar in the map's colour for its bin.
import {css, relative_colour, SCAN_SCALE_MM, edge_deviation} from './colours.js';

let chart = null;

// Draws into `canvas` the deviations of `result` (against the nominal when it has an inspection).
// Returns how many deviations it counted.
export function draw_histogram(canvas, result) {
  const inspected = !!result.inspection;
  const values = result.edge_points.map((p) => edge_deviation(p, inspected)).filter((d) => d).map((d) => d.value);
  if (chart) {
    chart.destroy();
    chart = null;
  }
  if (!values.length || !window.Chart) return values.length;
  // The scale the colours use: the edge profile tolerance against a nominal, else the scan's ±0.1 mm;
  // wider when the deviations are.
  const t = inspected && result.inspection.tolerances ? result.inspection.tolerances.edge_profile_mm : SCAN_SCALE_MM;
  const half = Math.max(t, ...values.map(Math.abs)) * 1.05;
  const bins = 21, width = (2 * half) / bins;
  const counts = new Array(bins).fill(0);
  for (const v of values) counts[Math.min(bins - 1, Math.max(0, Math.floor((v + half) / width)))] += 1;
  const centres = counts.map((_, i) => -half + (i + 0.5) * width);
  const colours = centres.map((c) => (Math.abs(c) > t && inspected ? 'rgb(215, 25, 35)' : css(relative_colour(c / t))));
  chart = new window.Chart(canvas.getContext('2d'), {
    type: 'bar',
    data: {
      labels: centres.map((c) => (Math.abs(c) < 5e-7 ? 0 : c).toFixed(3)),
      datasets: [{label: 'edge points', data: counts, backgroundColor: colours, barPercentage: 1, categoryPercentage: 1}],
    },
    options: {
      animation: false,
      responsive: true,
      maintainAspectRatio: false,
      plugins: {legend: {display: false}},
      scales: {
        x: {title: {display: true, text: inspected ? 'deviation from the nominal, mm' : 'deviation against the scan, mm'}},
        y: {title: {display: true, text: 'points'}, beginAtZero: true, ticks: {precision: 0}},
      },
    },
  });
  return values.length;
}
