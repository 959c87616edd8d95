// magcilia_mmc5983ma.ino -- reference firmware: a MEMSIC MMC5983MA 3-axis AMR magnetometer on I2C,
// streamed to the host in the magcilia serial protocol, version 1 (COBS + sequence number + CRC-32,
// docs/serial-protocol.md; the framing is magcilia_frame.h, plain C99, tested on the host).
//
// The host reads it as the force vector of a cilium above the part:
//
//     magcilia live --sensor mmc5983ma --source serial:/dev/ttyACM0 --setup my-cilium.toml
//
// (the frames' three channels are taken, in order, as the part's x, y, z field channels, in T:
// the frames' "volts per count" field carries tesla per count here, SCALE_T_PER_COUNT below).
//
// ---- Board and wiring (any Arduino with Wire; 3.3 V logic) ----------------------------------
//
//   MMC5983MA breakout (e.g. SparkFun SEN-19034 / SEN-19921, Qwiic)     Arduino
//     VDD, VDDIO ........................................................ 3.3V
//     GND ............................................................... GND
//     SDA, SCL .......................................................... SDA, SCL (4.7 kOhm
//                                                                          pull-ups to 3.3 V;
//                                                                          the breakouts have
//                                                                          them)
//   A 5 V board (Uno) needs a level shifter on SDA/SCL: the part's I/O is not 5 V tolerant.
//
// ---- Register settings, and where each comes from ---------------------------------------------
//
//   Source: MEMSIC, "MMC5983MA Datasheet", Rev A, 4/3/2019 (the register map and bit tables);
//   cross-checked here against four independent open drivers that cite it: SparkFun's
//   SparkFun_MMC5983MA_Magnetometer_Arduino_Library (src/..._Constants.h), Zephyr's MMC5983MA
//   driver (O. Neumann, 2024), K. Winer's Tlera MMC5983MA.h, and an STM32 driver
//   (MichalPoz/IIM42652_IMU, Core/Inc/mmc5983_regs.h). All agree on every value used below.
//   NOT verified here: the datasheet PDF itself could not be read from this workplace (only the
//   drivers that copy its tables), so each figure below is "as the drivers have it"; and none of
//   this was run on a real part. Check against your datasheet revision before trusting it.
//
//   I2C address 0x30 (7-bit), up to 400 kHz (fast mode)            MMC_ADDR, I2C_CLOCK_HZ
//   0x00-0x05 Xout0/1, Yout0/1, Zout0/1: bits [17:10] and [9:2]      REG_XOUT0
//   0x06 XYZout2: X[1:0] in bits 7:6, Y[1:0] in 5:4, Z[1:0] in 3:2    REG_XYZOUT2
//   0x08 Status: bit 0 Meas_M_Done (write 1 to clear)                REG_STATUS, MEAS_M_DONE
//   0x09 Internal control 0: bit 5 Auto_SR_en (automatic set/reset)   REG_CTRL0, AUTO_SR_EN
//   0x0A Internal control 1: BW[1:0] in bits 1:0 (00: 100 Hz bandwidth, 8 ms per measurement;
//        01: 200 Hz, 4 ms; 10: 400 Hz, 2 ms; 11: 800 Hz, 0.5 ms), bit 7 SW_RST   REG_CTRL1
//   0x0B Internal control 2: Cm_freq[2:0] in bits 2:0 (001 1 Hz, 010 10 Hz, 011 20 Hz,
//        100 50 Hz, 101 100 Hz, 110 200 Hz, 111 1000 Hz), bit 3 Cmm_en (continuous mode),
//        Prd_set[2:0] in bits 6:4 (set every 1, 25, 75, 100, 250, 500, 1000, 2000
//        measurements), bit 7 En_prd_set (periodic set)                 REG_CTRL2
//   0x2F Product ID: 0x30                                             REG_PRODUCT_ID
//   Output: 18-bit unsigned, 131072 (2^17) at zero field, 16384 counts per gauss over +-8 G,
//   i.e. 1/16384 G = 6.1035 nT per count (the datasheet's headline "0.0625 mG per LSB" rounds
//   the same step; NOTES section 7 quotes 6.25 nT). This sketch sends count - 131072 as int32.
//
//   Chosen: continuous mode at RATE_HZ = 100 Hz with BW 00 (100 Hz bandwidth, 8 ms per
//   measurement fits in the 10 ms period; the datasheet pairs 200 Hz with BW 01 and 1000 Hz with
//   BW 11 -- higher bandwidth, more noise), automatic set/reset with a set pulse every 100
//   measurements (once a second: restores the film after a strong field without costing
//   every sample). The frames carry flags 0: the part demodulates set/reset itself.
//
// ---- Rates ----------------------------------------------------------------------------------
//   3 channels x 10 samples per frame = 148 bytes (+ about 2 of COBS and delimiter) ten times a
//   second: 1.5 kB/s, fine at 115200 baud. The part's own oscillator sets the rate; its accuracy
//   is not given in the drivers' tables (unverified): if the host's time axis must be better
//   than that, measure the rate against a reference and give it to SerialSource(rate=...).
//
// ---- What the sketch does -------------------------------------------------------------------
//   setup(): serial, I2C, soft reset, product ID check (an ID other than 0x30 blinks the LED and
//   sends nothing), bandwidth, automatic set/reset, continuous mode.
//   loop(): polls Meas_M_Done, reads the 7 output bytes in one burst, clears the flag, puts the
//   three counts into the frame; every SAMPLES_PER_FRAME samples it finishes the frame (header,
//   CRC-32, COBS, 0x00) and writes it. A sample index counts every measurement the part made, so
//   a frame that could not be sent (the host's gap) shows as lost samples, never as a shift.

#include <Wire.h>

#include "magcilia_frame.h"

// ---- settings ----------------------------------------------------------------------------------
const uint32_t BAUD = 115200;
const uint32_t I2C_CLOCK_HZ = 400000;
const uint8_t MMC_ADDR = 0x30;
const float RATE_HZ = 100.0f;
const uint16_t SAMPLES_PER_FRAME = 10;
const uint8_t CHANNELS = 3;                       // x, y, z
const float SCALE_T_PER_COUNT = 1e-4f / 16384.0f; // 1/16384 G per count, in tesla
const int32_t ZERO_FIELD_COUNT = 131072;           // 2^17

// ---- registers (see the table above) -----------------------------------------------------------
const uint8_t REG_XOUT0 = 0x00;
const uint8_t REG_XYZOUT2 = 0x06;
const uint8_t REG_STATUS = 0x08;
const uint8_t REG_CTRL0 = 0x09;
const uint8_t REG_CTRL1 = 0x0A;
const uint8_t REG_CTRL2 = 0x0B;
const uint8_t REG_PRODUCT_ID = 0x2F;
const uint8_t PRODUCT_ID = 0x30;
const uint8_t MEAS_M_DONE = 0x01;  // status bit 0
const uint8_t AUTO_SR_EN = 0x20;   // control 0 bit 5
const uint8_t SW_RST = 0x80;       // control 1 bit 7
const uint8_t BW_100HZ = 0x00;     // control 1 bits 1:0 = 00
const uint8_t CM_FREQ_100HZ = 0x05;  // control 2 bits 2:0 = 101
const uint8_t CMM_EN = 0x08;         // control 2 bit 3
const uint8_t PRD_SET_100 = 0x30;    // control 2 bits 6:4 = 011: a set every 100 measurements
const uint8_t EN_PRD_SET = 0x80;     // control 2 bit 7

// ---- buffers -------------------------------------------------------------------------------------
uint8_t frame[MAGCILIA_FRAME_SIZE(SAMPLES_PER_FRAME, CHANNELS)];
uint8_t wire[MAGCILIA_WIRE_SIZE(SAMPLES_PER_FRAME, CHANNELS)];
uint16_t filled = 0;      // samples in the frame being filled
uint32_t sequence = 0;    // frames finished
uint32_t next_index = 0;  // index of the next sample since start (wraps at 2^32, as the host expects)
uint32_t frame_first = 0;

void write_reg(uint8_t reg, uint8_t value) {
  Wire.beginTransmission(MMC_ADDR);
  Wire.write(reg);
  Wire.write(value);
  Wire.endTransmission();
}

uint8_t read_regs(uint8_t reg, uint8_t *out, uint8_t n) {
  Wire.beginTransmission(MMC_ADDR);
  Wire.write(reg);
  if (Wire.endTransmission(false) != 0) return 0;  // repeated start
  uint8_t got = Wire.requestFrom(MMC_ADDR, n);
  for (uint8_t i = 0; i < got; i++) out[i] = Wire.read();
  return got;
}

void fail_forever() {  // no part, or another part: blink, send nothing (the host says it stalled)
  pinMode(LED_BUILTIN, OUTPUT);
  for (;;) {
    digitalWrite(LED_BUILTIN, !digitalRead(LED_BUILTIN));
    delay(200);
  }
}

void setup() {
  Serial.begin(BAUD);
  Wire.begin();
  Wire.setClock(I2C_CLOCK_HZ);
  write_reg(REG_CTRL1, SW_RST);
  delay(15);  // the reset and the OTP read after it: a few ms (15 ms is a margin; unverified)
  uint8_t id = 0;
  if (read_regs(REG_PRODUCT_ID, &id, 1) != 1 || id != PRODUCT_ID) fail_forever();
  write_reg(REG_CTRL1, BW_100HZ);
  write_reg(REG_CTRL0, AUTO_SR_EN);
  write_reg(REG_CTRL2, CMM_EN | CM_FREQ_100HZ | EN_PRD_SET | PRD_SET_100);
}

void finish() {  // header, CRC, COBS, delimiter; then send (a frame of `filled` samples: a short
                 // one after a failed read keeps the same sample-major layout, so nothing moves)
  size_t n = magcilia_finish_frame(frame, filled, CHANNELS, 0, sequence++, frame_first, RATE_HZ,
                                   SCALE_T_PER_COUNT, wire);
  Serial.write(wire, n);
  filled = 0;
}

void loop() {
  uint8_t status = 0;
  if (read_regs(REG_STATUS, &status, 1) != 1 || !(status & MEAS_M_DONE)) return;
  uint8_t b[7];
  uint8_t got = read_regs(REG_XOUT0, b, 7);  // Xout0 .. XYZout2 in one burst
  write_reg(REG_STATUS, MEAS_M_DONE);         // clear the flag (write 1)
  uint32_t index = next_index++;
  if (got != 7) {  // a failed read: the sample is lost; the host sees the gap in `first`
    if (filled) finish();
    return;
  }
  if (filled == 0) frame_first = index;
  int32_t x = (int32_t)(((uint32_t)b[0] << 10) | ((uint32_t)b[1] << 2) | ((b[6] >> 6) & 3u));
  int32_t y = (int32_t)(((uint32_t)b[2] << 10) | ((uint32_t)b[3] << 2) | ((b[6] >> 4) & 3u));
  int32_t z = (int32_t)(((uint32_t)b[4] << 10) | ((uint32_t)b[5] << 2) | ((b[6] >> 2) & 3u));
  magcilia_put_count(frame, CHANNELS, filled, 0, x - ZERO_FIELD_COUNT);
  magcilia_put_count(frame, CHANNELS, filled, 1, y - ZERO_FIELD_COUNT);
  magcilia_put_count(frame, CHANNELS, filled, 2, z - ZERO_FIELD_COUNT);
  if (++filled == SAMPLES_PER_FRAME) finish();
}
