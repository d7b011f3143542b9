'use strict';
// The mechanics behind one node-canopen encoder: an instrument axis held by a hand. The hand
// is a spring-damper pulling the axis towards a slowly moving hold position; the drive's
// torque (or force) acts on the axis's inertia (or mass):
//
//   J·ẍ = τ_drive + k·(h(t) − x) − b·ẋ,   h(t) = h0 + A·sin(2π f t)
//
// integrated with semi-implicit Euler at each SYNC, in sub-steps of at most MAX_STEP (the
// damping term is explicit: b·h/J < 2 is needed; the rotary axes' b/J is 250 /s). x in rad (rotary) or m (linear); the
// encoder reports round(x · counts_per_unit) counts, as numen's axis model (docs/protocol.md
// §2) decodes them. numen's own emulator plays a recorded trajectory instead; this plant is
// closed loop: the torque numen sends moves the encoders it reads.

const MAX_STEP = 0.001;  // s: the longest integration sub-step

class PlantAxis {
    /**
     * countsPerUnit: counts per rad or per m; hold: h0, rad or m; amplitude: A, rad or m;
     * frequency: f, Hz; inertia: J, kg·m² or kg; stiffness: k, N·m/rad or N/m; damping: b,
     * N·m·s/rad or N·s/m.
     */
    constructor({ countsPerUnit, hold, amplitude, frequency, inertia, stiffness, damping }) {
        Object.assign(this, { countsPerUnit, hold, amplitude, frequency, inertia, stiffness, damping });
        this.t = 0;
        this.x = hold;
        this.v = 0;
    }

    /** Advances by dt seconds under `torque` (N·m or N, held over dt); returns the encoder
     *  counts. */
    step(dt, torque) {
        const n = Math.max(1, Math.ceil(dt / MAX_STEP - 1e-9));
        const h = dt / n;
        for (let i = 0; i < n; ++i) {
            this.t += h;
            const target = this.hold + this.amplitude * Math.sin(2 * Math.PI * this.frequency * this.t);
            const a = (torque + this.stiffness * (target - this.x) - this.damping * this.v) / this.inertia;
            this.v += a * h;
            this.x += this.v * h;
        }
        return this.counts();
    }

    counts() {
        return Math.round(this.x * this.countsPerUnit);
    }
}

module.exports = { PlantAxis };
