/* magcilia_frame.h -- the framing of the magcilia serial protocol, version 1, in plain C99.
 *
 * What docs/serial-protocol.md defines and magcilia.acquire.protocol reads: a frame is
 *
 *     header (24 bytes, little-endian) | int32 counts[n][c] (sample-major) | CRC-32 (of all before)
 *
 * COBS-encoded (no 0x00 inside) and followed by one 0x00 delimiter. Nothing here depends on
 * Arduino: the sketch includes it, and tests/acquire/test_mmc5983ma_sketch.py compiles it on the
 * host (cc -std=c99 -Wall -Wextra -Werror -pedantic) and checks that it reproduces the worked
 * example of docs/serial-protocol.md byte for byte, and that these constants agree with
 * magcilia/acquire/protocol.py.
 */
#ifndef MAGCILIA_FRAME_H
#define MAGCILIA_FRAME_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* ---- the protocol's constants (protocol.py: VERSION, FRAME_SAMPLES, FLAG_*, HEADER, ...) ---- */
#define MAGCILIA_VERSION 1u             /* byte 0 */
#define MAGCILIA_FRAME_SAMPLES 1u       /* byte 1: a block of samples */
#define MAGCILIA_FLAG_SETRESET_VALID 0x01u
#define MAGCILIA_FLAG_SET 0x02u
#define MAGCILIA_HEADER_SIZE 24u        /* B B B B H H I I f f */
#define MAGCILIA_CRC_SIZE 4u
#define MAGCILIA_MAX_FRAME 16384u       /* header + counts + CRC, decoded */
/* CRC-32 of zlib / ISO-HDLC: reflected polynomial, initial value and final XOR */
#define MAGCILIA_CRC32_POLY 0xEDB88320uL
#define MAGCILIA_CRC32_INIT 0xFFFFFFFFuL
#define MAGCILIA_CRC32_XOROUT 0xFFFFFFFFuL
#define MAGCILIA_DELIMITER 0x00u

/* header field offsets (docs/serial-protocol.md, "The decoded frame") */
#define MAGCILIA_OFF_VERSION 0u
#define MAGCILIA_OFF_TYPE 1u
#define MAGCILIA_OFF_FLAGS 2u
#define MAGCILIA_OFF_CHANNELS 3u
#define MAGCILIA_OFF_SAMPLES 4u
#define MAGCILIA_OFF_RESERVED 6u
#define MAGCILIA_OFF_SEQUENCE 8u
#define MAGCILIA_OFF_FIRST 12u
#define MAGCILIA_OFF_RATE 16u
#define MAGCILIA_OFF_SCALE 20u

/* bytes of a frame of n samples of c channels: decoded, and on the wire (COBS + delimiter) */
#define MAGCILIA_FRAME_SIZE(n, c) (MAGCILIA_HEADER_SIZE + 4u * (n) * (c) + MAGCILIA_CRC_SIZE)
#define MAGCILIA_WIRE_SIZE(n, c) (MAGCILIA_FRAME_SIZE(n, c) + MAGCILIA_FRAME_SIZE(n, c) / 254u + 2u)

static void magcilia_put_u16(uint8_t *p, uint16_t v) {
  p[0] = (uint8_t)(v & 0xFFu);
  p[1] = (uint8_t)(v >> 8);
}

static void magcilia_put_u32(uint8_t *p, uint32_t v) {
  p[0] = (uint8_t)(v & 0xFFu);
  p[1] = (uint8_t)((v >> 8) & 0xFFu);
  p[2] = (uint8_t)((v >> 16) & 0xFFu);
  p[3] = (uint8_t)(v >> 24);
}

static void magcilia_put_f32(uint8_t *p, float v) {
  uint32_t bits; /* IEEE 754 binary32 on every Arduino core and host compiler this targets */
  memcpy(&bits, &v, sizeof bits);
  magcilia_put_u32(p, bits);
}

/* CRC-32 bit by bit (no table: RAM is scarce on small boards); crc32("123456789") = 0xCBF43926 */
static uint32_t magcilia_crc32(const uint8_t *data, size_t n) {
  uint32_t crc = MAGCILIA_CRC32_INIT;
  while (n--) {
    int k;
    crc ^= *data++;
    for (k = 0; k < 8; k++) {
      crc = (crc >> 1) ^ (MAGCILIA_CRC32_POLY & (0uL - (crc & 1uL)));
    }
  }
  return crc ^ MAGCILIA_CRC32_XOROUT;
}

/* COBS (Cheshire & Baker 1999): out receives no 0x00; returns its length (<= n + n / 254 + 1) */
static size_t magcilia_cobs_encode(const uint8_t *in, size_t n, uint8_t *out) {
  size_t code_at = 0, o = 1, i;
  uint8_t code = 1;
  for (i = 0; i < n; i++) {
    if (in[i] == 0) {
      out[code_at] = code;
      code_at = o++;
      code = 1;
    } else {
      out[o++] = in[i];
      if (++code == 0xFF && i + 1 < n) { /* a full block; a new one only if bytes follow */
        out[code_at] = code;
        code_at = o++;
        code = 1;
      }
    }
  }
  out[code_at] = code;
  return o;
}

/* Write the header into frame[0..23] (the counts must be at frame[24..], 4 n c bytes, little-
 * endian int32), append the CRC-32, COBS-encode the whole into wire and end it with 0x00.
 * Returns the bytes to send (<= MAGCILIA_WIRE_SIZE(n, c)). frame must hold
 * MAGCILIA_FRAME_SIZE(n, c) bytes. scale is the unit per count (V for a voltage ADC). */
static size_t magcilia_finish_frame(uint8_t *frame, uint16_t n, uint8_t c, uint8_t flags,
                                    uint32_t sequence, uint32_t first, float rate,
                                    float scale, uint8_t *wire) {
  size_t size = MAGCILIA_HEADER_SIZE + 4u * (size_t)n * c, len;
  frame[MAGCILIA_OFF_VERSION] = MAGCILIA_VERSION;
  frame[MAGCILIA_OFF_TYPE] = MAGCILIA_FRAME_SAMPLES;
  frame[MAGCILIA_OFF_FLAGS] = flags;
  frame[MAGCILIA_OFF_CHANNELS] = c;
  magcilia_put_u16(frame + MAGCILIA_OFF_SAMPLES, n);
  magcilia_put_u16(frame + MAGCILIA_OFF_RESERVED, 0);
  magcilia_put_u32(frame + MAGCILIA_OFF_SEQUENCE, sequence);
  magcilia_put_u32(frame + MAGCILIA_OFF_FIRST, first);
  magcilia_put_f32(frame + MAGCILIA_OFF_RATE, rate);
  magcilia_put_f32(frame + MAGCILIA_OFF_SCALE, scale);
  magcilia_put_u32(frame + size, magcilia_crc32(frame, size));
  len = magcilia_cobs_encode(frame, size + MAGCILIA_CRC_SIZE, wire);
  wire[len] = MAGCILIA_DELIMITER;
  return len + 1;
}

/* the count of sample s, channel ch of a frame of c channels */
static void magcilia_put_count(uint8_t *frame, uint8_t c, uint16_t s, uint8_t ch, int32_t v) {
  magcilia_put_u32(frame + MAGCILIA_HEADER_SIZE + 4u * ((size_t)s * c + ch), (uint32_t)v);
}

#endif /* MAGCILIA_FRAME_H */
