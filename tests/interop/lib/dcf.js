'use strict';
// A device configuration file (DCF, CiA 306) loaded into a node-canopen object dictionary.
//
// node-canopen's Eds reads each object's DefaultValue and nothing of what makes a DCF a DCF:
// it ignores ParameterValue (the configured value), [DeviceComissioning] (the node id) and
// $NODEID expressions. loadDcf() therefore resolves "$NODEID+0x180"-style values to numbers
// first (CiA 306 §4.6.3), lets Eds load that text, then writes every ParameterValue over the
// object dictionary; applyParameterValues() does it again after an NMT reset, which in
// node-canopen restores every DefaultValue (a configured device restores its stored
// configuration).

const fs = require('fs');
const os = require('os');
const path = require('path');
const ini = require('ini');
const { Eds } = require('canopen');

/**
 * Loads `file` for node `nodeId` (1-127; may be omitted when the file's [DeviceComissioning]
 * gives NodeID, and must then agree with it). Returns {path, eds, nodeId, parameterValues:
 * [[index, subIndex|null, value text]]}, the ParameterValues written into eds unless `apply`
 * is false (the device as it leaves the factory: DefaultValues). Throws naming the file for a
 * bad or missing node id and for a ParameterValue without an object.
 */
function loadDcf(file, nodeId, { apply = true } = {}) {
    const text = fs.readFileSync(file, 'utf-8');
    const parsed = ini.parse(text);
    const stated = parsed.DeviceComissioning && parsed.DeviceComissioning.NodeID;
    if (nodeId === undefined)
        nodeId = Number(stated);
    else if (stated !== undefined && Number(stated) !== nodeId)
        throw new Error(`${file}: [DeviceComissioning] NodeID ${stated} but the node is ${nodeId}`);
    if (!Number.isInteger(nodeId) || nodeId < 1 || nodeId > 127)
        throw new Error(`${file}: node id '${nodeId}' is not 1-127 ([DeviceComissioning] NodeID)`);

    // Eds.fromFile() reads a path: the resolved text goes through a temporary file.
    const resolved = text.replace(/^((?:DefaultValue|ParameterValue)\s*=\s*)\$NODEID\s*\+\s*(\S+)\s*$/gmi,
        (_, key, offset) => `${key}0x${(nodeId + Number(offset)).toString(16)}`);
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'numen-dcf-'));
    const tmp = path.join(dir, path.basename(file));
    fs.writeFileSync(tmp, resolved);
    let eds;
    try {
        eds = Eds.fromFile(tmp);
    } finally {
        fs.rmSync(dir, { recursive: true, force: true });
    }

    const parameterValues = [];
    for (const [section, keys] of Object.entries(ini.parse(resolved))) {
        if (keys.ParameterValue === undefined)
            continue;
        const m = /^([0-9A-Fa-f]{4})(?:sub([0-9A-Fa-f]+))?$/.exec(section);
        if (!m)
            throw new Error(`${file}: [${section}] ParameterValue outside an object section`);
        parameterValues.push([parseInt(m[1], 16), m[2] === undefined ? null : parseInt(m[2], 16),
            keys.ParameterValue]);
    }
    const dcf = { path: file, eds, nodeId, parameterValues };
    if (apply)
        applyParameterValues(dcf);
    return dcf;
}

/** Writes every ParameterValue of `dcf` into its object dictionary. */
function applyParameterValues(dcf) {
    for (const [index, subIndex, text] of dcf.parameterValues) {
        const entry = subIndex === null ? dcf.eds.getEntry(index) : dcf.eds.getSubEntry(index, subIndex);
        if (!entry)
            throw new Error(`${dcf.path}: ParameterValue of [${index.toString(16).toUpperCase()}`
                + `${subIndex === null ? '' : 'sub' + subIndex.toString(16)}] has no object`);
        entry.value = isNumericType(entry.dataType) ? Number(text) : text;
    }
}

// CiA 301 data types 0x01-0x08 and 0x10-0x1B are numbers; 0x09 visible string, 0x0A octet
// string, 0x0B unicode string, 0x0F domain are not.
function isNumericType(dataType) {
    return (dataType >= 0x01 && dataType <= 0x08) || (dataType >= 0x10 && dataType <= 0x1b);
}

module.exports = { loadDcf, applyParameterValues };
