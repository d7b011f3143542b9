'use strict';
// The interop tests' framing (lib/serial_frame.js) against numen's own test vectors: the CRC
// check value of crc16.hpp and the two frames on the line of docs/transports.md "Serial line", which
// tests/hal/transport/serial_frame_test.cpp asserts on the C++ side.

const test = require('node:test');
const assert = require('node:assert');
const { crc16, cobsEncode, cobsDecode, encodeFrame, SerialFrameDecoder } = require('./lib/serial_frame');

const hex = (s) => Buffer.from(s.replace(/ /g, ''), 'hex');

test('CRC-16/IBM-3740 check value of "123456789" is 0x29B1', () => {
    assert.strictEqual(crc16(Buffer.from('123456789', 'ascii')), 0x29b1);
});

test('encoder TPDO of node 1 (0x181, 34 12 00 00) on the line', () => {
    const line = encodeFrame({ id: 0x181, data: hex('34120000') });
    assert.deepStrictEqual(line, hex('01 03 81 01 01 04 04 34 12 01 03 B0 66 00'));
});

test('decoder: the extended frame 0x1ABCDEF1 of docs/transports.md "Serial line"', () => {
    const d = new SerialFrameDecoder();
    const frames = d.feed(hex('11 01 F1 DE BC 1A 08 11 22 33 44 55 66 77 88 D3 E4 00'));
    assert.strictEqual(frames.length, 1);
    assert.strictEqual(frames[0].flags, 0x01);
    assert.strictEqual(frames[0].id, 0x1abcdef1);
    assert.deepStrictEqual(frames[0].data, hex('1122334455667788'));
});

test('decoder: byte by byte, idle fill, a corrupted frame rejected and the next one kept', () => {
    const good = encodeFrame({ id: 0x701, data: hex('7F') });
    const bad = Buffer.from(good);
    bad[4] ^= 0x10;  // one flipped bit: the CRC fails
    const d = new SerialFrameDecoder();
    const frames = [];
    for (const b of Buffer.concat([hex('00 00'), bad, good]))
        frames.push(...d.feed([b]));
    assert.strictEqual(frames.length, 1);
    assert.deepStrictEqual(frames[0], { flags: 0, id: 0x701, data: hex('7F') });
    assert.strictEqual(d.rejected, 1);
});

test('COBS round trip of every payload length 0-72 with zeros at every position', () => {
    for (let n = 0; n <= 72; ++n) {
        for (let z = -1; z < n; ++z) {
            const p = Buffer.alloc(n, 0xa5);
            if (z >= 0)
                p[z] = 0;
            const e = cobsEncode(p);
            assert.strictEqual(e.length, n + 1);
            assert.ok(!e.includes(0));
            assert.deepStrictEqual(cobsDecode(e), p);
        }
    }
});
