// The numen viewer's entry (docs/viewer.md "Page"). Loads three.js first: when the build could
// not install it (vendor/MISSING says why), the page says what to install instead of showing a
// blank canvas; else loads the page's modules (js/main.js and what it imports).
//
// URL parameters: ?frame=I (replay: show frame I, paused), ?w=W&h=H (the view's size in
// pixels), ?aa=0|1 (multisampling), ?perf=1 (render timed to the GPU's end): docs/viewer.md.
// window.numenView exposes the state a test reads (also written to #probe as JSON).
import { fail } from './js/panel.js';

try {
  await import('three');
  await import('three/addons/controls/OrbitControls.js');
} catch (e) {
  let why = '';
  try { why = await (await fetch('vendor/MISSING')).text(); } catch (_) { /* none */ }
  fail('three.js could not be loaded: the build did not install the page\'s libraries.\n' +
       (why || String(e)) + '\nInstall nodejs and npm, then rebuild (docs/viewer.md "Page").');
  throw e;
}
await import('./js/main.js');
