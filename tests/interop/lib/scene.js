'use strict';
// What the node-canopen side needs of a numen scene file (docs/scenes.md "Device"): each CANopen
// node's id and DCF, from the same keys numen reads, so that node-canopen builds its devices
// from the DCFs numen configures them from; and a copy of a scene with other DCFs.
//
// Not a TOML parser: the scene's tables are followed line by line, and only `key = "string"`
// and `key = number` values of the tables below are read (each on one line, as numen's scenes
// write them). Read:
//   [device] first_node_id                   (default 1)
//   [[device.axis]] rated_torque             (N·m or N; the drives' 1000 per mille)
//   [device.canopen] dcf                     (every node's DCF unless its axis gives one)
//   [[device.canopen.axis]] node_id, dcf     (in the order of [[device.axis]]; node_id default
//                                             first_node_id + axis index)
// DCF paths are relative to the scene file's directory.

const fs = require('fs');
const path = require('path');

/** The scene's lines, each with the table it is in ('device.canopen.axis' for every
 *  [[device.canopen.axis]]), the table's ordinal among tables of that name (0-based), and the
 *  key and raw value text when the line is `key = value`. */
function sceneLines(text) {
    const counts = {};
    let table = '';
    let ordinal = -1;
    return text.split('\n').map((line) => {
        const header = /^\s*(\[\[?)\s*([A-Za-z0-9_.]+)\s*\]\]?\s*(#.*)?$/.exec(line);
        if (header) {
            table = header[2];
            counts[table] = (counts[table] === undefined ? -1 : counts[table]) + 1;
            ordinal = counts[table];
            return { line, table, ordinal, header: true };
        }
        const kv = /^\s*([A-Za-z0-9_]+)\s*=\s*("(?:[^"\\]|\\.)*"|[^#\s]+)/.exec(line);
        return kv ? { line, table, ordinal, key: kv[1], raw: kv[2] } : { line, table, ordinal };
    });
}

function value(raw) {
    if (raw.startsWith('"'))
        return JSON.parse(raw);
    const n = Number(raw.replace(/_/g, ''));
    if (Number.isNaN(n))
        throw new Error(`'${raw}' is neither a string nor a number`);
    return n;
}

/**
 * The scene's CANopen nodes: [{nodeId, dcf (absolute path), axes: [axis index], ratedTorque
 * (of its first driven axis, N·m or N; undefined without one)}], in node order of first
 * appearance. Throws naming the scene when an axis has no DCF.
 */
function sceneNodes(scenePath) {
    const sceneDir = path.dirname(path.resolve(scenePath));
    const lines = sceneLines(fs.readFileSync(scenePath, 'utf-8'));
    const get = (table, key, ordinal) => {
        const l = lines.find((x) => x.table === table && x.key === key
            && (ordinal === undefined || x.ordinal === ordinal));
        return l ? value(l.raw) : undefined;
    };
    const firstNodeId = get('device', 'first_node_id') ?? 1;
    const defaultDcf = get('device.canopen', 'dcf');
    const axes = Math.max(...lines.filter((l) => l.header && l.table === 'device.axis').map((l) => l.ordinal + 1), 0);
    const canopenAxes = Math.max(...lines.filter((l) => l.header && l.table === 'device.canopen.axis').map((l) => l.ordinal + 1), 0);
    const count = Math.max(axes, canopenAxes);
    const nodes = [];
    for (let a = 0; a < count; ++a) {
        const nodeId = (canopenAxes > 0 ? get('device.canopen.axis', 'node_id', a) : undefined) ?? firstNodeId + a;
        const dcf = (canopenAxes > 0 ? get('device.canopen.axis', 'dcf', a) : undefined) ?? defaultDcf;
        if (dcf === undefined)
            throw new Error(`${scenePath}: axis ${a} (node ${nodeId}) has no dcf ([[device.canopen.axis]] dcf or [device.canopen] dcf)`);
        const ratedTorque = get('device.axis', 'rated_torque', a);
        let node = nodes.find((n) => n.nodeId === nodeId);
        if (!node) {
            node = { nodeId, dcf: path.resolve(sceneDir, dcf), axes: [], ratedTorque: undefined };
            nodes.push(node);
        }
        node.axes.push(a);
        if (node.ratedTorque === undefined)
            node.ratedTorque = ratedTorque;
    }
    return nodes;
}

/**
 * The text of the scene `scenePath` for a copy in another directory: every relative `file` and
 * `dcf` path made absolute (relative to the scene's directory), and the DCF of node n replaced
 * by `dcfOverrides[n]` where given (in its [[device.canopen.axis]] table: the existing `dcf`
 * value replaced, or a `dcf` key added when the table has none). The axes and their tables
 * stay as they are: nothing is appended.
 */
function sceneTextWithDcfs(scenePath, dcfOverrides = {}) {
    const sceneDir = path.dirname(path.resolve(scenePath));
    const nodes = sceneNodes(scenePath);
    const nodeOfAxis = {};
    for (const n of nodes)
        for (const a of n.axes)
            nodeOfAxis[a] = n.nodeId;
    const used = new Set();
    const out = [];
    const lines = sceneLines(fs.readFileSync(scenePath, 'utf-8'));
    for (let i = 0; i < lines.length; ++i) {
        const l = lines[i];
        const axisTable = l.table === 'device.canopen.axis';
        const override = axisTable ? dcfOverrides[nodeOfAxis[l.ordinal]] : undefined;
        if ((l.key === 'dcf' || l.key === 'file') && l.raw.startsWith('"')) {
            const given = value(l.raw);
            let to = path.isAbsolute(given) ? given : path.resolve(sceneDir, given);
            if (l.key === 'dcf' && override !== undefined) {
                to = override;
                used.add(l.ordinal);
            }
            out.push(l.line.replace(l.raw, JSON.stringify(to)));
        } else {
            out.push(l.line);
        }
        // The end of a [[device.canopen.axis]] table whose node is overridden but has no dcf.
        const next = lines[i + 1];
        const ends = !next || next.header;
        if (axisTable && ends && override !== undefined && !used.has(l.ordinal)) {
            out.push(`dcf = ${JSON.stringify(override)}`);
            used.add(l.ordinal);
        }
    }
    for (const id of Object.keys(dcfOverrides)) {
        const node = nodes.find((n) => n.nodeId === Number(id));
        if (!node || !node.axes.some((a) => used.has(a)))
            throw new Error(`${scenePath}: no [[device.canopen.axis]] of node ${id} to give the DCF ${dcfOverrides[id]}`);
    }
    return out.join('\n');
}

module.exports = { sceneNodes, sceneTextWithDcfs };
