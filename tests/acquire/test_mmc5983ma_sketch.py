"""The reference sketch for an I²C 3-axis part (firmware/magcilia_mmc5983ma): its framing
constants agree with magcilia.acquire.protocol, its framing code (compiled on this machine with
the C compiler) reproduces docs/serial-protocol.md's worked example byte for byte, and the whole
sketch, run on the host against a simulated MMC5983MA (registers as the datasheet's tables have
them, written here independently), sends frames the host parses into the part's fields."""

from __future__ import annotations

import re
import shutil
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest

from magcilia.acquire import protocol
from magcilia.acquire.protocol import FrameParser, encode_frame

ROOT = Path(__file__).resolve().parents[2]
SKETCH = ROOT / "firmware" / "magcilia_mmc5983ma"
HEADER = SKETCH / "magcilia_frame.h"
CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
CXX = shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) here")
needs_cxx = pytest.mark.skipif(CXX is None, reason="no C++ compiler (c++, g++) here")

#: docs/serial-protocol.md's worked example on the wire
DOC_WIRE = bytes.fromhex(
    "06 01 01 03 01 03 01 01 02 07 01 01 02 e0 01 01 01 01 09 7a 44 6f 12 83 34 e8 03 01 08 18"
    " fc ff ff 40 e2 01 05 a1 ea 85 78 00")


def _defines(path: Path) -> dict[str, int]:
    """``#define NAME 0x..u`` integer constants of a C file."""
    found = re.findall(r"^#define\s+(MAGCILIA_\w+)\s+(0x[0-9A-Fa-f]+|\d+)u?L?\b", path.read_text(),
                       re.MULTILINE)
    return {name: int(value, 0) for name, value in found}


def _crc32_bitwise(data: bytes, poly: int, init: int, xorout: int) -> int:
    crc = init
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (poly if crc & 1 else 0)
    return crc ^ xorout


def test_sketch_constants_agree_with_the_protocol() -> None:
    d = _defines(HEADER)
    assert d["MAGCILIA_VERSION"] == protocol.VERSION
    assert d["MAGCILIA_FRAME_SAMPLES"] == protocol.FRAME_SAMPLES
    assert d["MAGCILIA_FLAG_SETRESET_VALID"] == protocol.FLAG_SETRESET_VALID
    assert d["MAGCILIA_FLAG_SET"] == protocol.FLAG_SET
    assert d["MAGCILIA_HEADER_SIZE"] == protocol.HEADER.size
    assert d["MAGCILIA_CRC_SIZE"] == protocol.CRC_SIZE
    assert d["MAGCILIA_MAX_FRAME"] == protocol.MAX_FRAME
    assert bytes([d["MAGCILIA_DELIMITER"]]) == protocol.DELIMITER
    # the CRC parameters give the host's CRC (zlib's) on any bytes
    for data in (b"123456789", bytes(range(256)), b"\x00" * 7):
        assert _crc32_bitwise(data, d["MAGCILIA_CRC32_POLY"], d["MAGCILIA_CRC32_INIT"],
                              d["MAGCILIA_CRC32_XOROUT"]) == zlib.crc32(data)
    # each field's offset is where the host's struct puts it: <B B B B H H I I f f
    fmt = protocol.HEADER.format
    codes = fmt.lstrip("<")
    offsets = [struct.calcsize("<" + codes[:i]) for i in range(len(codes))]
    names = ["VERSION", "TYPE", "FLAGS", "CHANNELS", "SAMPLES", "RESERVED", "SEQUENCE", "FIRST",
             "RATE", "SCALE"]
    assert [d[f"MAGCILIA_OFF_{n}"] for n in names] == offsets


def _run_c(tmp_path: Path, body: str) -> str:
    src = tmp_path / "harness.c"
    src.write_text(f'#include <stdio.h>\n#include "{HEADER}"\nint main(void)\n{{\n{body}\n'
                   "    return 0;\n}\n")
    exe = tmp_path / "harness"
    assert CC is not None
    subprocess.run([CC, "-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", "-pedantic",
                    "-Wno-unused-function", "-o", str(exe), str(src)], check=True,
                   capture_output=True, text=True)
    return subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout


@needs_cc
def test_framing_code_reproduces_the_documented_frame(tmp_path: Path) -> None:
    body = """
    uint8_t frame[MAGCILIA_FRAME_SIZE(70, 1)], wire[MAGCILIA_WIRE_SIZE(70, 1)];
    size_t n, i;
    magcilia_put_count(frame, 1, 0, 0, 1000);
    magcilia_put_count(frame, 1, 1, 0, -1000);
    magcilia_put_count(frame, 1, 2, 0, 123456);
    n = magcilia_finish_frame(frame, 3, 1, MAGCILIA_FLAG_SETRESET_VALID | MAGCILIA_FLAG_SET,
                              7, 224, 1000.0f, 2.048f / 8388608.0f, wire);
    for (i = 0; i < n; i++) printf("%02x", wire[i]);
    printf("\\n%08lx\\n", (unsigned long)magcilia_crc32((const uint8_t *)"123456789", 9));
    for (i = 0; i < 70; i++) magcilia_put_count(frame, 1, (uint16_t)i, 0, (int32_t)(i * 77 + 1));
    n = magcilia_finish_frame(frame, 70, 1, 0, 4294967295uL, 4294967290uL, 250.0f, 1e-6f, wire);
    for (i = 0; i < n; i++) printf("%02x", wire[i]);
    printf("\\n");
    """
    doc, crc, long = _run_c(tmp_path, body).split()
    assert bytes.fromhex(doc) == DOC_WIRE
    assert bytes.fromhex(doc) == encode_frame([1000, -1000, 123456], sequence=7, first=224,
                                              rate=1000.0, volts_per_count=2.048 / 2**23,
                                              setreset=1)
    assert int(crc, 16) == 0xCBF43926
    counts = np.arange(70) * 77 + 1  # 308 decoded bytes: COBS blocks past 254
    assert bytes.fromhex(long) == encode_frame(counts, sequence=2**32 - 1, first=2**32 - 6,
                                               rate=250.0, volts_per_count=1e-6)


#: an Arduino core and an MMC5983MA on its I²C bus, for the host: the part's registers as the
#: datasheet's tables have them (address 0x30, product ID 0x30 at 0x2F, 18-bit outputs with
#: 2^17 at zero field, X/Y/Z[17:10], [9:2] at 0x00-0x05 and their bits [1:0] in 0x06's 7:6,
#: 5:4, 3:2, Meas_M_Done in status bit 0, cleared by writing 1)
MOCK = r"""
#pragma once
#include <stdint.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#define LED_BUILTIN 13
#define OUTPUT 1
static uint8_t regs[64];
static uint8_t last_write[64];
static int pointer = 0;
static long field_index = 0;
static uint32_t raw_of(long i, int axis) {
  return (uint32_t)(131072 + (i * 37 + axis * 1000) % 90000 - 45000);
}
static void measure(void) {
  uint32_t v[3];
  for (int a = 0; a < 3; a++) v[a] = raw_of(field_index, a);
  field_index++;
  for (int a = 0; a < 3; a++) {
    regs[2 * a] = (uint8_t)(v[a] >> 10);
    regs[2 * a + 1] = (uint8_t)((v[a] >> 2) & 0xFF);
  }
  regs[6] = (uint8_t)(((v[0] & 3) << 6) | ((v[1] & 3) << 4) | ((v[2] & 3) << 2));
  regs[8] |= 0x01;
}
struct TwoWire {
  uint8_t buf[8]; int n = 0; int rd = 0; uint8_t out[8]; int out_n = 0; uint8_t addr = 0;
  void begin() {}
  void setClock(uint32_t) {}
  void beginTransmission(uint8_t a) { addr = a; n = 0; }
  size_t write(uint8_t b) { buf[n++] = b; return 1; }
  uint8_t endTransmission(bool = true) {
    if (addr != 0x30) return 2;
    pointer = buf[0];
    if (n == 2) {
      last_write[pointer] = buf[1];
      if (pointer == 0x08) regs[8] &= (uint8_t)~(buf[1] & 0x01);
      else regs[pointer] = buf[1];
    }
    return 0;
  }
  uint8_t requestFrom(uint8_t, uint8_t count) {
    out_n = count; rd = 0;
    for (int i = 0; i < count; i++) out[i] = regs[pointer + i];
    return count;
  }
  int read() { return out[rd++]; }
} Wire;
struct SerialPort {
  void begin(uint32_t) {}
  size_t write(const uint8_t *b, size_t n) { fwrite(b, 1, n, stdout); return n; }
} Serial;
static void delay(unsigned long) {}
static void pinMode(int, int) {}
static void digitalWrite(int, int) {}
static int digitalRead(int) { return 0; }
void finish();
"""

RUNNER = r"""
int main() {
  regs[0x2F] = 0x30;
  setup();
  fprintf(stderr, "%02x %02x %02x\n", last_write[0x09], last_write[0x0A], last_write[0x0B]);
  for (int k = 0; k < 45; k++) { measure(); loop(); loop(); }
  fflush(stdout);
  return 0;
}
"""


@needs_cxx
def test_sketch_on_a_simulated_part_streams_its_fields(tmp_path: Path) -> None:
    (tmp_path / "Wire.h").write_text(MOCK)
    src = tmp_path / "sketch.cpp"
    src.write_text((SKETCH / "magcilia_mmc5983ma.ino").read_text() + RUNNER)  # <Wire.h>: MOCK
    exe = tmp_path / "sketch"
    assert CXX is not None
    subprocess.run([CXX, "-std=c++17", "-O1", "-Wall", "-Wextra", "-Werror",
                    "-Wno-unused-function", f"-I{tmp_path}", f"-I{SKETCH}", "-o", str(exe),
                    str(src)], check=True, capture_output=True, text=True)
    run = subprocess.run([str(exe)], check=True, capture_output=True)
    # control 0: Auto_SR_en; control 1: BW 00 (after the soft reset); control 2: Cmm_en,
    # Cm_freq 101 (100 Hz), En_prd_set, Prd_set 011 (every 100 measurements)
    assert run.stderr.decode().split() == ["20", "00", "bd"]
    parser = FrameParser()
    frames = parser.feed(run.stdout)
    assert parser.corrupt == 0 and len(frames) == 4  # 45 samples, 10 per frame
    counts = np.concatenate([f.counts for f in frames])
    i = np.arange(40)[:, None]
    raw = 131072 + (i * 37 + np.arange(3) * 1000) % 90000 - 45000
    np.testing.assert_array_equal(counts, raw - 131072)
    first = frames[0]
    assert (first.rate, first.channels, first.setreset) == (100.0, 3, 0)
    assert first.volts_per_count == pytest.approx(1e-4 / 16384, rel=1e-6)  # T per count
    assert [f.sequence for f in frames] == [0, 1, 2, 3]
    assert [f.first for f in frames] == [0, 10, 20, 30]


def _vector_live(spec: str) -> object:
    from magcilia.cli._live import build_live

    return build_live(source_spec=spec, setup_arg="force-sensor", quantity="force",
                      span_text=None, calibration_path=None, fluid="water", rate=None,
                      source_rate=None, channel="output", set_reset=None, no_tare=False,
                      tracking=30.0, seed=0, tip_radius=None, modulus=None,
                      sensor_name="mmc5983ma")


@pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs a pseudo-terminal")
def test_a_3_axis_part_in_the_framed_protocol_reads_as_a_force_vector() -> None:
    """What the sketch sends (three channels, T per count, 100 Hz) read by `live --sensor
    mmc5983ma --source serial:PORT`: the frames' channels become the part's x, y, z."""
    from magcilia.acquire.emulator import DeviceEmulator

    simulated = _vector_live("sim").source  # the simulated part's x, y, z fields, T
    with DeviceEmulator(simulated, samples_per_frame=10, volts_per_count=1e-4 / 16384) as device:
        live = _vector_live(f"serial:{device.port}")
        live.start()
        try:
            live.history.wait(60, 10.0)  # past the tare
            samples, _, _ = live.history.since(0)
            status = live.status
        finally:
            live.stop()
    assert status.state in ("running", "taring") and status.counters.unverified == 0
    assert [c.name for c in live.source.channels] == list(live.sensor.inputs)
    assert samples.value.shape[1:] == (2,) and np.isfinite(samples.value[-10:]).all()
