'use strict';
// What the node-canopen side needs of a numen scene file (docs/scenes.md "Device"):
//   sceneNodes         each CANopen node's id, DCF and the rated torque of its first axis, as
//                      numen itself reads them (`numen info --json`, its "device" object), so
//                      that node-canopen builds its devices from the DCFs numen configures them
//                      from;
//   sceneTextWithDcfs  a copy of a scene with other DCFs and other settings, the scene parsed
//                      and written back by smol-toml (a TOML 1.0 library, pinned in
//                      package-lock.json); its comments are not kept.

const { execFileSync } = require('child_process');
const path = require('path');
const fs = require('fs');
const TOML = require('smol-toml');

/**
 * The scene's CANopen nodes as `numen info --json` (numen at `numenPath`) gives them:
 * [{nodeId, dcf (absolute path), axes: [axis index], ratedTorque (of its first axis, N·m or N)}],
 * in node order of first appearance. Throws naming the scene when numen cannot load it, its
 * device is not on the managed stack, or a node has no DCF.
 */
function sceneNodes(numenPath, scenePath) {
    let info;
    try {
        info = JSON.parse(execFileSync(numenPath, ['info', scenePath, '--json'], { encoding: 'utf-8' }));
    } catch (e) {
        throw new Error(`${scenePath}: numen info --json failed: ${e.stderr || e.message}`);
    }
    const device = info.device;
    if (!device.managed)
        throw new Error(`${scenePath}: device '${device.name}' is not on the managed CANopen stack`);
    return device.nodes.map((n) => {
        if (!n.dcf)
            throw new Error(`${scenePath}: node ${n.node_id} (axis ${n.axes.join(', ')}) has no dcf ([[device.canopen.axis]] dcf or [device.canopen] dcf)`);
        return { nodeId: n.node_id, dcf: n.dcf, axes: n.axes, ratedTorque: device.axes[n.axes[0]].rated_torque };
    });
}

/** Every relative `dcf` and `file` string under `value` made absolute against `dir`, in place. */
function absolutise(value, dir) {
    if (Array.isArray(value)) {
        value.forEach((v) => absolutise(v, dir));
    } else if (value !== null && typeof value === 'object') {
        for (const [key, v] of Object.entries(value)) {
            if ((key === 'dcf' || key === 'file') && typeof v === 'string')
                value[key] = path.isAbsolute(v) ? v : path.resolve(dir, v);
            else
                absolutise(v, dir);
        }
    }
}

/**
 * The text of the scene `scenePath` for a copy in another directory: every relative `file` and
 * `dcf` path made absolute (relative to the scene's directory), the DCF of node n set to
 * `dcfOverrides[n]` in each of its [[device.canopen.axis]] tables (nodes from sceneNodes(),
 * numen at `numenPath`), then `edit(doc)` applied to the parsed scene. Throws when a node to
 * override has no [[device.canopen.axis]] table.
 */
function sceneTextWithDcfs(numenPath, scenePath, dcfOverrides = {}, edit = () => {}) {
    const doc = TOML.parse(fs.readFileSync(scenePath, 'utf-8'));
    absolutise(doc, path.dirname(path.resolve(scenePath)));
    const overrides = Object.entries(dcfOverrides);
    if (overrides.length > 0) {
        const nodes = sceneNodes(numenPath, scenePath);
        const tables = doc.device?.canopen?.axis;
        for (const [id, dcf] of overrides) {
            const node = nodes.find((n) => n.nodeId === Number(id));
            if (!node || !Array.isArray(tables) || !node.axes.every((a) => tables[a]))
                throw new Error(`${scenePath}: no [[device.canopen.axis]] of node ${id} to give the DCF ${dcf}`);
            for (const a of node.axes)
                tables[a].dcf = dcf;
        }
    }
    edit(doc);
    return TOML.stringify(doc);
}

module.exports = { sceneNodes, sceneTextWithDcfs };
