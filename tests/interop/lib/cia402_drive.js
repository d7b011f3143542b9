'use strict';
// A minimal CiA 402 power drive system state machine (CiA 402-2 / IEC 61800-7-201 §6.3, as
// docs/canopen.md "CiA 402 drives" reads it) on top of a node-canopen object dictionary: controlword
// 0x6040 in, statusword 0x6041 out, cyclic synchronous torque (modes of operation 0x6060 = 10):
// target torque 0x6071 (per mille of the rated torque), clipped to max torque 0x6072,
// reported in torque actual value 0x6077. The rated torque is motor rated torque 0x6076 where
// the dictionary has it; numen's shipped DCFs have none (numen takes the rated torque from the
// scene's [[device.axis]] rated_torque, not from the drive), so the drive is then given it:
// option ratedTorque, mN·m (mN), default 1000 (1 N·m or 1 N at 1000 per mille). Stepped once per SYNC with the values the last RPDO
// wrote (node-canopen applies an RPDO when it arrives, whatever its transmission type; reading
// them at SYNC makes the RPDO synchronous). Error code 0x603F, where the dictionary has it,
// holds the last fault.

const State = Object.freeze({
    NOT_READY: 'not ready to switch on',
    SWITCH_ON_DISABLED: 'switch on disabled',
    READY: 'ready to switch on',
    SWITCHED_ON: 'switched on',
    OPERATION_ENABLED: 'operation enabled',
    QUICK_STOP_ACTIVE: 'quick stop active',
    FAULT_REACTION_ACTIVE: 'fault reaction active',
    FAULT: 'fault',
});

// Statusword of each state: the bits of the state (0-3, 5, 6), voltage enabled (4) where the
// power stage is on, remote (9) always: the typical drive values of docs/canopen.md "CiA 402 drives".
const STATUSWORD = Object.freeze({
    [State.NOT_READY]: 0x0200,
    [State.SWITCH_ON_DISABLED]: 0x0250,
    [State.READY]: 0x0231,
    [State.SWITCHED_ON]: 0x0233,
    [State.OPERATION_ENABLED]: 0x0237,
    [State.QUICK_STOP_ACTIVE]: 0x0217,
    [State.FAULT_REACTION_ACTIVE]: 0x021f,
    [State.FAULT]: 0x0218,
});

const MODE_CST = 10;  // cyclic synchronous torque

/** The command a controlword codes (bits 7, 3-0), CiA 402 table "device control commands". */
function decodeControlword(cw) {
    if (cw & 0x80)
        return 'fault reset';
    if ((cw & 0x02) === 0)
        return 'disable voltage';
    if ((cw & 0x04) === 0)
        return 'quick stop';
    if ((cw & 0x01) === 0)
        return 'shutdown';
    return (cw & 0x08) ? 'enable operation' : 'switch on';
}

// Objects the state machine reads or writes; 0x603F (error code) and 0x6076 (motor rated
// torque) are used when present.
const REQUIRED = [0x6040, 0x6041, 0x6060, 0x6061, 0x6071, 0x6072, 0x6077];

const DEFAULT_RATED_TORQUE = 1000;  // mN·m (mN), where neither 0x6076 nor ratedTorque gives it

class Cia402Drive {
    /** `device`: a node-canopen Device whose dictionary has the REQUIRED objects (throws naming
     *  the missing ones and `source`, e.g. the DCF's path). `ratedTorque`: mN·m (mN), used when
     *  the dictionary has no 0x6076 (default DEFAULT_RATED_TORQUE). */
    constructor(device, source, { ratedTorque = DEFAULT_RATED_TORQUE } = {}) {
        const missing = REQUIRED.filter((i) => device.eds.getEntry(i) === undefined);
        if (missing.length > 0)
            throw new Error(`${source}: a CiA 402 drive needs ${missing.map((i) => '0x' + i.toString(16).toUpperCase()).join(', ')}`);
        this.device = device;
        this.hasErrorCode = device.eds.getEntry(0x603f) !== undefined;
        this.hasRatedTorque = device.eds.getEntry(0x6076) !== undefined;
        this.ratedTorqueDefault = ratedTorque;
        this.state = State.NOT_READY;
        this.lastControlword = 0;
        this.faults = [];       // {code, state} of every fault, in order
        this.transitions = 0;
        this.publish(0);
    }

    get energised() {
        return this.state === State.SWITCHED_ON || this.state === State.OPERATION_ENABLED
            || this.state === State.QUICK_STOP_ACTIVE;
    }

    /** Transition 13 at once: fault reaction active, error code `code` (0x603F). */
    fault(code) {
        if (this.state === State.FAULT || this.state === State.FAULT_REACTION_ACTIVE)
            return;
        this.faults.push({ code, state: this.state });
        if (this.hasErrorCode)
            this.device.setValue(0x603f, code);
        this.go(State.FAULT_REACTION_ACTIVE);
        this.publish(0);
    }

    /** One SYNC: automatic transitions, the controlword's command, then the output torque.
     *  Returns the torque applied, N·m (or N), from the rated torque (mN·m or mN). */
    step() {
        // Automatic transitions 1 (initialisation done) and 14 (fault reaction completed).
        if (this.state === State.NOT_READY)
            this.go(State.SWITCH_ON_DISABLED);
        else if (this.state === State.FAULT_REACTION_ACTIVE)
            this.go(State.FAULT);
        else if (this.state === State.QUICK_STOP_ACTIVE)
            this.go(State.SWITCH_ON_DISABLED);  // transition 12: stopped (no ramp modelled)

        const cw = this.device.getValue(0x6040);
        const command = decodeControlword(cw);
        const rising = (cw & 0x80) !== 0 && (this.lastControlword & 0x80) === 0;
        this.lastControlword = cw;
        this.apply(command, rising);

        const mode = this.device.getValue(0x6060);
        this.device.setValue(0x6061, mode);
        let perMille = 0;
        if (this.state === State.OPERATION_ENABLED && mode === MODE_CST && (cw & 0x100) === 0) {
            const max = this.device.getValue(0x6072);
            perMille = Math.max(-max, Math.min(max, this.device.getValue(0x6071)));
        }
        this.publish(perMille);
        return perMille / 1000 * this.ratedTorque / 1000;
    }

    /** mN·m (mN): 0x6076 where the dictionary has it, else the one the drive was given. */
    get ratedTorque() {
        return this.hasRatedTorque ? this.device.getValue(0x6076) : this.ratedTorqueDefault;
    }

    apply(command, rising) {
        const s = this.state;
        switch (command) {
            case 'fault reset':
                if (s === State.FAULT && rising) {
                    if (this.hasErrorCode)
                        this.device.setValue(0x603f, 0);
                    this.go(State.SWITCH_ON_DISABLED);  // 15
                }
                break;
            case 'disable voltage':
                if (s === State.READY || s === State.SWITCHED_ON || s === State.OPERATION_ENABLED
                    || s === State.QUICK_STOP_ACTIVE)
                    this.go(State.SWITCH_ON_DISABLED);  // 7, 9, 10, 12
                break;
            case 'quick stop':
                if (s === State.READY || s === State.SWITCHED_ON)
                    this.go(State.SWITCH_ON_DISABLED);  // 7, 10
                else if (s === State.OPERATION_ENABLED)
                    this.go(State.QUICK_STOP_ACTIVE);  // 11
                break;
            case 'shutdown':
                if (s === State.SWITCH_ON_DISABLED || s === State.SWITCHED_ON
                    || s === State.OPERATION_ENABLED)
                    this.go(State.READY);  // 2, 6, 8
                break;
            case 'switch on':
                if (s === State.READY || s === State.OPERATION_ENABLED)
                    this.go(State.SWITCHED_ON);  // 3, 5
                break;
            case 'enable operation':
                if (s === State.READY || s === State.SWITCHED_ON)
                    this.go(State.OPERATION_ENABLED);  // 3 + 4, 4
                break;
        }
    }

    go(state) {
        if (state !== this.state) {
            this.state = state;
            ++this.transitions;
        }
    }

    publish(perMille) {
        this.device.setValue(0x6041, STATUSWORD[this.state]);
        this.device.setValue(0x6077, perMille);
    }
}

module.exports = { Cia402Drive, State, STATUSWORD, decodeControlword };
