'use strict';
// The instrument's CANopen nodes played by node-canopen (npm `canopen`, CiA 301: NMT,
// heartbeat, SDO server, PDO, SYNC, EMCY), one Device per DCF, on one serial line to numen.
//
// What this file adds on top of node-canopen, each for a CiA 301 / 402 / 406 behaviour numen's
// master relies on (docs/sdo.md):
// - the boot-up message (0x700 + node, 00) on entering pre-operational, which node-canopen
//   6.2 does not send;
// - the configured values restored after an NMT reset (dcf.js), or, for nodes a master is to
//   configure, the unconfigured state (PDOs off, no heartbeat: dcf.js applyUnconfigured);
// - at each SYNC, before node-canopen sends its synchronous TPDOs: the CiA 402 drive stepped
//   with the last RPDO's controlword and target torque (cia402_drive.js), the plant integrated
//   under the applied torque (plant_axis.js), and the CiA 406 position value 0x6004 latched;
// - the drive's own protection: controller heartbeat lost (consumer 0x1016) → fault 0x8130,
//   node leaving operational while energised → fault 0x8100, each with its EMCY;
// - the predefined connection set's default SDO channel (0x600 / 0x580 + node) and EMCY COB-ID
//   (0x080 + node) when the DCF lists no 0x1200 / 0x1014: node-canopen serves SDO and sends
//   EMCY only on channels its dictionary lists.

const { NmtState } = require('canopen');
const { Device } = require('canopen');
const { loadDcf, applyParameterValues, applyUnconfigured } = require('./dcf');
const { Cia402Drive } = require('./cia402_drive');
const { PlantAxis } = require('./plant_axis');

const CONTROLLER_NODE = 127;  // numen's heartbeat producer (0x77F)

class Node {
    /** `ratedTorque`: the drive's rated torque, mN·m (mN), where the DCF has no 0x6076. */
    constructor(dcf, plant, ratedTorque) {
        this.dcf = dcf;
        this.id = dcf.nodeId;
        if (dcf.eds.getSdoServerParameters().length === 0)
            dcf.eds.addSdoServerParameter(0, 0x580 + this.id, 0x600 + this.id, { saveDefault: true });
        if (!dcf.eds.getEntry(0x1014))
            dcf.eds.setEmcyCobId(0x080 + this.id, { saveDefault: true });
        this.device = new Device({ eds: dcf.eds, id: dcf.nodeId });
        this.plant = plant ? new PlantAxis(plant) : null;
        // A CiA 402 drive where the dictionary has the drive objects (device type profile 402).
        this.drive = (this.device.getValue(0x1000) & 0xffff) === 402
            ? new Cia402Drive(this.device, dcf.path, { ratedTorque }) : null;
        this.counters = { rpdos: 0, rpdosNonzero: 0, tpdos: 0, sdoRequests: 0, bootups: 0,
            heartbeats: 0, emcys: 0, resets: 0 };
        // Every SDO initiate request the node received, in order: {kind: 'download' |
        // 'upload', index, subIndex, value (expedited downloads; null otherwise)}.
        this.sdoLog = [];
        // When each heartbeat was handed to the line, s of CLOCK_MONOTONIC (numen's clock).
        this.heartbeatTimes = [];
    }

    get operational() {
        return this.device.state === NmtState.OPERATIONAL;
    }
}

class NodeSet {
    /**
     * dcfs: one {path, nodeId, ratedTorque} per node (nodeId may be omitted when the DCF's
     * [DeviceComissioning] gives it; ratedTorque, N·m or N, is the drive's where its DCF has no
     * 0x6076: the scene's rated_torque); plants: {nodeId: PlantAxis options} for the nodes with
     * an encoder (0x6004); syncPeriod: s, when the DCFs have no 0x1006. Options: configured
     * (default true): the nodes hold their DCF's configured values (ParameterValue), at
     * power-on and after every NMT reset; false: they hold the DCF's DefaultValues with the
     * PDOs and heartbeats the DCF configures switched off (dcf.js applyUnconfigured), at
     * power-on and after every NMT reset, until a master writes the configuration.
     * bootUp (default true): the script sends the boot-up message node-canopen leaves out;
     * false shows what a master sees without it.
     */
    constructor(dcfs, plants, syncPeriod, { configured = true, bootUp = true } = {}) {
        this.configured = configured;
        this.bootUp = bootUp;
        this.nodes = dcfs.map(({ path, nodeId, ratedTorque }) => {
            const dcf = loadDcf(path, nodeId, { apply: configured });
            if (!configured)
                applyUnconfigured(dcf);
            return new Node(dcf, plants[dcf.nodeId], ratedTorque === undefined ? undefined : ratedTorque * 1000);
        });
        this.link = null;
        this.syncs = 0;
        this.framesIn = 0;
        this.nmtCommands = [];
        this.exceptions = [];
        const first = this.nodes[0].device;
        this.syncCobId = first.getValue(0x1005) & 0x7ff;
        const cycle = first.eds.getEntry(0x1006);  // communication cycle period, µs
        this.syncPeriod = cycle && cycle.value > 0 ? cycle.value * 1e-6 : syncPeriod;
    }

    /** Sends every node's frames on `link` from now on. */
    attach(link) {
        this.link = link;
    }

    start() {
        for (const node of this.nodes) {
            const { device } = node;
            device.on('message', (m) => this.send(node, m));
            let previous = device.state;
            device.nmt.on('changeState', (state) => {
                if (this.bootUp && previous === NmtState.INITIALIZING
                    && state === NmtState.PRE_OPERATIONAL) {
                    device.nmt.send(0x700 + node.id, Buffer.from([0]));  // boot-up
                    ++node.counters.bootups;
                }
                if (node.drive && node.drive.energised && previous === NmtState.OPERATIONAL
                    && state !== NmtState.OPERATIONAL)
                    this.driveFault(node, 0x8100);  // abort connection (0x6007 = 1)
                previous = state;
            });
            device.nmt.on('timeout', (id) => {
                if (id === CONTROLLER_NODE && node.drive)
                    this.driveFault(node, 0x8130);  // life guard / heartbeat error
            });
            device.start();
            // After device.start(): node-canopen's own reset listener (which restores every
            // VAR object's DefaultValue) runs first, then this one restores the configuration,
            // or the unconfigured state.
            device.nmt.on('reset', () => {
                ++node.counters.resets;
                if (this.configured)
                    applyParameterValues(node.dcf);
                else
                    applyUnconfigured(node.dcf);
            });
        }
    }

    stop() {
        for (const node of this.nodes)
            node.device.stop();
    }

    /** One frame from numen. */
    receive(frame) {
        ++this.framesIn;
        if (frame.id === 0)
            this.nmtCommands.push(Buffer.from(frame.data).toString('hex'));
        if (frame.id === this.syncCobId && frame.data.length <= 1) {
            ++this.syncs;
            for (const node of this.nodes)
                if (node.operational)
                    this.latch(node);
        }
        // Broadcasts (NMT, SYNC, heartbeats: every node may consume them) reach every node;
        // the rest only the node that has the frame's RPDO or SDO channel (less work per
        // period for node's event loop, which paces the answers to numen's SYNC).
        const broadcast = frame.id === 0 || frame.id === this.syncCobId || (frame.id & 0x780) === 0x700;
        for (const node of this.nodes) {
            const rpdo = node.operational && node.device.pdo.receiveMap[frame.id] !== undefined;
            const sdo = node.device.sdoServer.transfers[frame.id] !== undefined;
            if (!broadcast && !rpdo && !sdo)
                continue;
            if (sdo) {
                ++node.counters.sdoRequests;
                logSdo(node, frame.data);
            }
            try {
                node.device.receive(frame);
            } catch (e) {
                // A frame node-canopen's stack throws on (e.g. an expedited SDO download shorter
                // than the object): recorded, and the node goes on, as a device would.
                this.exceptions.push(`node ${node.id}, frame ${frame.id.toString(16)}#`
                    + `${Buffer.from(frame.data).toString('hex')}: ${e.message}`);
            }
            if (rpdo) {
                ++node.counters.rpdos;
                if (node.device.getValue(0x6071) !== 0)
                    ++node.counters.rpdosNonzero;
            }
        }
    }

    // The node's state at this SYNC, before its synchronous TPDOs go out.
    latch(node) {
        const torque = node.drive ? node.drive.step() : 0;
        if (node.plant) {
            const raw = Buffer.alloc(4);
            raw.writeInt32LE(node.plant.step(this.syncPeriod, torque));
            node.device.setRaw(0x6004, raw);
        }
    }

    driveFault(node, code) {
        if (node.drive.state === 'fault' || node.drive.state === 'fault reaction active')
            return;
        node.drive.fault(code);
        node.drive.faults[node.drive.faults.length - 1].afterSyncs = this.syncs;
        if (node.device.emcy.started)  // not in stopped
            node.device.emcy.write(code);  // positional form: write({code}) is broken in 6.2.1
    }

    send(node, m) {
        const id = m.id;
        if (id === 0x080 + node.id)
            ++node.counters.emcys;
        else if (id === 0x700 + node.id && m.data[0] !== 0) {
            ++node.counters.heartbeats;
            node.heartbeatTimes.push(Number(process.hrtime.bigint()) * 1e-9);
        }
        else if (node.device.pdo.transmitMap[id] !== undefined)
            ++node.counters.tpdos;
        if (this.link)
            this.link.send(m);
    }

    /** Counters per node, for the scenario's report. */
    report() {
        return {
            syncs: this.syncs, framesIn: this.framesIn, nmt: this.nmtCommands.slice(0, 8),
            exceptions: this.exceptions,
            nodes: this.nodes.map((n) => ({ id: n.id, state: n.device.state,
                drive: n.drive ? { state: n.drive.state, faults: n.drive.faults } : null,
                ...n.counters })),
        };
    }
}

/** Records an SDO initiate request (CiA 301 §7.2.4.3: client command specifier 1, download;
 *  2, upload) in node.sdoLog. */
function logSdo(node, data) {
    const d = Buffer.from(data);
    if (d.length < 4)
        return;
    const ccs = d[0] >> 5;
    if (ccs !== 1 && ccs !== 2)
        return;
    const index = d.readUInt16LE(1);
    const subIndex = d[3];
    let value = null;
    if (ccs === 1 && (d[0] & 0x02) && d.length === 8) {  // expedited
        const size = (d[0] & 0x01) ? 4 - ((d[0] >> 2) & 0x03) : 4;
        value = d.readUIntLE(4, size);
    }
    node.sdoLog.push({ kind: ccs === 1 ? 'download' : 'upload', index, subIndex, value });
}

module.exports = { NodeSet };
