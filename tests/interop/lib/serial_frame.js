'use strict';
// numen's serial-line framing of CAN frames (docs/transports.md "Serial line", serial_frame.hpp), for the
// node-canopen side of the interoperability tests.
//
// Payload (before stuffing), 8 + d bytes: flags u8 (CanFlag bits, 6-7 reserved = 0), id u32
// little endian, len u8, data (d = len bytes; 0 for a remote request), CRC-16/IBM-3740 of the
// bytes before it, big endian. On the line: COBS(payload) (Cheshire & Baker 1999) then one
// 0x00 delimiter, 10 + d bytes per frame. Only the classic 11-bit data frames node-canopen
// sends and receives are built here; every decoded frame's flags are reported to the caller.

// CRC-16/IBM-3740 table: the register after shifting each byte value through, MSB first.
const CRC_TABLE = new Uint16Array(256);
for (let b = 0; b < 256; ++b) {
    let c = b << 8;
    for (let i = 0; i < 8; ++i)
        c = (c & 0x8000) ? ((c << 1) ^ 0x1021) & 0xffff : (c << 1) & 0xffff;
    CRC_TABLE[b] = c;
}

/** CRC-16/IBM-3740 (poly 0x1021, init 0xFFFF, no reflection, xorout 0), check 0x29B1. */
function crc16(bytes, crc = 0xffff) {
    for (let i = 0; i < bytes.length; ++i)
        crc = ((crc << 8) & 0xffff) ^ CRC_TABLE[((crc >> 8) ^ bytes[i]) & 0xff];
    return crc;
}

/** COBS encoding of `input` (a frame payload is at most 72 bytes: never a 0xFF block). */
function cobsEncode(input) {
    const out = [0];
    let code = 0;  // index of the current block's code byte in out
    for (const b of input) {
        if (b === 0) {
            out[code] = out.length - code;
            code = out.length;
            out.push(0);
        } else {
            out.push(b);
            if (out.length - code === 0xff) {
                out[code] = 0xff;
                code = out.length;
                out.push(0);
            }
        }
    }
    out[code] = out.length - code;
    return Buffer.from(out);
}

/** COBS decoding of one chunk (no delimiter); null if a code byte points past its end. */
function cobsDecode(chunk) {
    const out = [];
    let i = 0;
    while (i < chunk.length) {
        const code = chunk[i];
        if (code === 0 || i + code > chunk.length)
            return null;
        for (let k = 1; k < code; ++k)
            out.push(chunk[i + k]);
        i += code;
        if (code !== 0xff && i < chunk.length)
            out.push(0);
    }
    return Buffer.from(out);
}

/**
 * The bytes on the line of one 11-bit classic data frame {id, data} (data: 0-8 bytes), the
 * 0x00 delimiter included.
 */
function encodeFrame({ id, data }) {
    if (!Number.isInteger(id) || id < 0 || id > 0x7ff)
        throw new RangeError(`serial frame: id ${id} is not an 11-bit CAN id`);
    if (data.length > 8)
        throw new RangeError(`serial frame: ${data.length} data bytes (at most 8)`);
    const n = 8 + data.length;  // payload: flags, id (4), len, data, CRC (2)
    const payload = Buffer.allocUnsafe(n);
    payload[0] = 0;  // flags: 11-bit classic data frame
    payload.writeUInt32LE(id, 1);
    payload[5] = data.length;
    for (let i = 0; i < data.length; ++i)
        payload[6 + i] = data[i];
    payload.writeUInt16BE(crc16(payload.subarray(0, n - 2)), n - 2);
    // COBS (a payload of at most 72 bytes never has a 0xFF block) and the delimiter.
    const out = Buffer.allocUnsafe(n + 2);
    let code = 0;
    let o = 1;
    for (let i = 0; i < n; ++i) {
        if (payload[i] === 0) {
            out[code] = o - code;
            code = o++;
        } else {
            out[o++] = payload[i];
        }
    }
    out[code] = o - code;
    out[o] = 0;
    return out;
}

/**
 * Streaming decoder: feed() takes received bytes in pieces of any size and returns the intact
 * frames {flags, id, data} they complete. Chunks that are not a frame (wrong length, COBS,
 * CRC or layout) are counted in `rejected`, never returned; decoding resumes after the next
 * 0x00, as numen's SerialFrameDecoder does.
 */
class SerialFrameDecoder {
    constructor() {
        this.chunk = Buffer.alloc(74);  // one byte more than the longest frame: marks it too long
        this.length = 0;
        this.frames = 0;
        this.rejected = 0;
    }

    feed(bytes) {
        const frames = [];
        for (let i = 0; i < bytes.length; ++i) {
            const b = bytes[i];
            if (b !== 0) {
                if (this.length < this.chunk.length)
                    this.chunk[this.length] = b;
                ++this.length;
                continue;
            }
            const length = this.length;
            this.length = 0;
            if (length === 0)
                continue;  // idle fill
            const chunk = this.chunk.subarray(0, Math.min(length, this.chunk.length));
            const frame = this._decodeChunk(chunk);
            if (frame) {
                ++this.frames;
                frames.push(frame);
            } else {
                ++this.rejected;
            }
        }
        return frames;
    }

    _decodeChunk(chunk) {
        if (chunk.length < 9 || chunk.length > 73)
            return null;
        const p = cobsDecode(chunk);
        if (!p || p.length < 8)
            return null;
        const body = p.length - 2;
        if (crc16(p.subarray(0, body)) !== p.readUInt16BE(body))
            return null;
        const flags = p[0];
        const len = p[5];
        const remote = (flags & 0x02) !== 0;
        if ((flags & 0xc0) !== 0 || body !== 6 + (remote ? 0 : len))
            return null;
        return { flags, id: p.readUInt32LE(1), data: Buffer.from(p.subarray(6, body)) };
    }
}

module.exports = { crc16, cobsEncode, cobsDecode, encodeFrame, SerialFrameDecoder };
