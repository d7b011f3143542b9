// The legend (docs/viewer.md "Page"): what each colour means, the contacts' depth scale of
// the frame shown and the force arrows' scale.
import { COLORS } from './geometry.js';
import { THREAD_COLOR } from './suture.js';

const el = document.getElementById('legend');
const hex = (c) => '#' + c.toString(16).padStart(6, '0');
const swatch = (c, text, cls = '') => `<span class="sw ${cls}" style="background:${c}"></span>${text}`;
el.innerHTML =
  [swatch(hex(COLORS.tool), 'tool'), swatch(hex(COLORS.body), 'body'), swatch(hex(COLORS.ghost), 'ghost (hand\'s target)'),
   swatch(hex(COLORS.obstacle), 'organ, obstacle'), swatch(hex(COLORS.box), 'box'), swatch(hex(COLORS.net), 'deformable'),
   swatch(hex(COLORS.plane), 'ground'), swatch(hex(COLORS.spheres), 'collision spheres'),
   swatch(hex(THREAD_COLOR), 'suture thread', 'line'),
   swatch('#e0f4ff', 'coupling spring (ghost → body)', 'line'), swatch('#ffee00', 'force sent to the device', 'line')]
    .map((s) => `<span class="item">${s}</span>`).join('') +
  '<div class="item"><span class="sw grad"></span><span id="legend-depth"></span></div>' +
  '<div class="item" id="legend-force"></div>';
const depthEl = document.getElementById('legend-depth'), forceEl = document.getElementById('legend-force');

/// Writes the scales of the frame shown: `scale` = { m_per_n, max_n, depth_m } (contacts.js).
export function showLegend(scale) {
  depthEl.textContent = `contacts by depth: 0 → ${(1e3 * scale.depth_m).toFixed(2)} mm (deepest shown)`;
  forceEl.textContent = scale.m_per_n > 0
    ? `contact force arrows: 1 N = ${(1e3 * scale.m_per_n).toFixed(1)} mm (largest seen ${scale.max_n.toFixed(2)} N)`
    : '';
}
