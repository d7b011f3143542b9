'use strict';
// One end of a serial line carrying numen's framing (serial_frame.js), on the master side of
// a pseudo-terminal whose slave numen opens (`--bus serial:PATH`). The pseudo-terminal pairs
// are made by pty_pairs.py, which hands their file descriptors to this process
// (NUMEN_INTEROP_PTYS); node opens them as tty streams (libuv sets them non-blocking), so no
// native module is needed.

const tty = require('tty');
const { encodeFrame, SerialFrameDecoder } = require('./serial_frame');

/** The pseudo-terminals pty_pairs.py opened: [{path, master, writer, slave}] (fds). */
function inheritedPtys() {
    const text = process.env.NUMEN_INTEROP_PTYS;
    if (!text)
        throw new Error('NUMEN_INTEROP_PTYS is not set: run this script through pty_pairs.py');
    return JSON.parse(text);
}

/**
 * A line to numen: receive() hands every intact frame {id, data} to `onFrame`, send() writes
 * one. Counts frames each way and chunks rejected.
 */
class SerialLink {
    constructor(pty, onFrame) {
        this.path = pty.path;
        this.decoder = new SerialFrameDecoder();
        this.sent = 0;
        this.pending = [];
        this.closed = false;
        this.reader = new tty.ReadStream(pty.master);
        this.reader.setRawMode(true);
        this.writer = new tty.WriteStream(pty.writer);
        this.reader.on('data', (bytes) => {
            for (const f of this.decoder.feed(bytes)) {
                // numen sends classic 11-bit data frames only; anything else is not CANopen.
                if (f.flags === 0)
                    onFrame({ id: f.id, data: f.data });
            }
        });
        // EIO when numen closes its end while no other slave descriptor is open: the line is
        // gone (never expected: pty_pairs.py keeps a slave descriptor open in this process).
        this.reader.on('error', (e) => { this.closed = true; this.error = e; });
        this.writer.on('error', (e) => { this.closed = true; this.error = e; });
    }

    /** Queues one frame; the frames queued while one event is handled (e.g. every TPDO of a
     *  SYNC) go out in one write(2), in order. */
    send(frame) {
        if (this.closed)
            return;
        this.pending.push(encodeFrame(frame));
        ++this.sent;
        if (this.pending.length === 1)
            queueMicrotask(() => this.flush());
    }

    flush() {
        if (this.closed || this.pending.length === 0)
            return;
        this.writer.write(Buffer.concat(this.pending));
        this.pending = [];
    }

    get received() {
        return this.decoder.frames;
    }

    get rejected() {
        return this.decoder.rejected;
    }

    close() {
        this.closed = true;
        this.reader.destroy();
        this.writer.destroy();
    }
}

module.exports = { SerialLink, inheritedPtys };
