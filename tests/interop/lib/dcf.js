'use strict';
// A device configuration file (DCF, CiA 306) loaded into a node-canopen object dictionary.
//
// node-canopen's Eds reads each object's DefaultValue and nothing of what makes a DCF a DCF:
// it ignores ParameterValue (the configured value), [DeviceComissioning] (the node id) and
// $NODEID expressions, and reads a 0-prefixed number as decimal. loadDcf() therefore first
// rewrites the values numen reads differently (docs/sdo.md: `$NODEID`, `$NODEID+N`,
// `N+$NODEID`, octal `0NNN`) as plain numbers, lets Eds load that text, then writes every
// ParameterValue over the object dictionary; applyParameterValues() does it again after an NMT
// reset, which in node-canopen restores the DefaultValue of every VAR object (a configured
// device restores its stored configuration). applyUnconfigured() gives a device as it leaves
// the factory instead (see there).

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
    const resolved = text.replace(/^(\s*(?:DefaultValue|ParameterValue)\s*=\s*)(.*?)\s*$/gmi,
        (line, key, v) => {
            const n = integerExpression(v, nodeId);
            return n === null ? line : `${key}${n}`;
        });
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

/**
 * Writes, over what the dictionary holds, the state of the device before any master has
 * configured it: every PDO whose COB-ID the DCF configures switched off (COB-ID bit 31 set:
 * the PDO does not exist, CiA 301 §7.5.2.35), every mapping whose count the DCF configures
 * emptied (count 0), and no heartbeat where the DCF configures one (producer 0x1017 = 0,
 * consumer 0x1016:n = 0). A DCF whose DefaultValues are the configuration (numen's shipped
 * DCFs give DefaultValue = ParameterValue) would otherwise leave nothing for the master to
 * configure.
 */
function applyUnconfigured(dcf) {
    for (const [index, subIndex] of dcf.parameterValues) {
        const entry = subIndex === null ? dcf.eds.getEntry(index) : dcf.eds.getSubEntry(index, subIndex);
        if (isPdoCommunication(index) && subIndex === 1)
            entry.value = (entry.value | 0x80000000) >>> 0;
        else if (isPdoMapping(index) && subIndex === 0)
            entry.value = 0;
        else if (index === 0x1017 || (index === 0x1016 && subIndex > 0))
            entry.value = 0;
    }
}

/** RPDO (0x1400-0x15FF) or TPDO (0x1800-0x19FF) communication parameter (CiA 301 §7.5.2.35). */
function isPdoCommunication(index) {
    return (index >= 0x1400 && index <= 0x15ff) || (index >= 0x1800 && index <= 0x19ff);
}

/** RPDO (0x1600-0x17FF) or TPDO (0x1A00-0x1BFF) mapping parameter (CiA 301 §7.5.2.36). */
function isPdoMapping(index) {
    return (index >= 0x1600 && index <= 0x17ff) || (index >= 0x1a00 && index <= 0x1bff);
}

/**
 * The number an integer value of a DCF stands for, as numen reads it (docs/sdo.md):
 * decimal, 0x hexadecimal or 0-prefixed octal, optionally negative; `$NODEID`, `$NODEID+N`
 * and `N+$NODEID` (case-insensitive) with the node's id. Returns null for any other text (a
 * string value; node-canopen reads it as it is).
 */
function integerExpression(text, nodeId) {
    const number = (t) => {
        if (/^-?0[xX][0-9a-fA-F]+$/.test(t))
            return (t.startsWith('-') ? -1 : 1) * parseInt(t.replace(/^-/, '').slice(2), 16);
        if (/^-?0[0-7]+$/.test(t))
            return (t.startsWith('-') ? -1 : 1) * parseInt(t.replace(/^-/, ''), 8);
        if (/^-?[0-9]+$/.test(t))
            return parseInt(t, 10);
        return null;
    };
    const terms = text.replace(/\s+/g, '').split('+');
    if (terms.length === 1 && terms[0].toLowerCase() !== '$nodeid') {
        // Plain numbers are left to node-canopen but for octal, which it would read as decimal.
        return /^-?0[0-7]+$/.test(terms[0]) ? number(terms[0]) : null;
    }
    if (terms.length > 2 || terms.filter((t) => t.toLowerCase() === '$nodeid').length !== 1)
        return null;
    const other = terms.find((t) => t.toLowerCase() !== '$nodeid');
    if (other === undefined)
        return nodeId;
    const n = number(other);
    return n === null || n < 0 ? null : nodeId + n;
}

// CiA 301 data types 0x01-0x08 and 0x10-0x1B are numbers; 0x09 visible string, 0x0A octet
// string, 0x0B unicode string, 0x0F domain are not.
function isNumericType(dataType) {
    return (dataType >= 0x01 && dataType <= 0x08) || (dataType >= 0x10 && dataType <= 0x1b);
}

module.exports = { loadDcf, applyParameterValues, applyUnconfigured, isPdoCommunication };
