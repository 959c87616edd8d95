// magcilia_stream.ino -- reference firmware: an HMC1021 AMR bridge read by an ADS1220 24-bit ADC,
// streamed to the host in the magcilia serial protocol, version 1 (docs/serial-protocol.md).
//
// A reference for a lab, written to be read against docs/serial-protocol.md; it uses nothing but
// the Arduino core and its SPI library (COBS and CRC-32 are implemented below). The host side is
// magcilia.acquire.serial.SerialSource:
//
//     from magcilia.acquire.serial import SerialSource
//     with SerialSource("/dev/ttyACM0", baudrate=115200) as source:
//         block = source.read(1000)          # 1 s of samples, V, with gaps and losses counted
//
// ---- Board and wiring (Arduino Uno / Nano, 5 V logic; other boards: change the pin numbers) -----
//
//   ADS1220 (TSSOP-16 breakout)     Arduino
//     DVDD, AVDD ................... 5V   (100 nF + 10 uF to ground, close to the chip)
//     DGND, AVSS ................... GND
//     SCLK ......................... D13 (SCK)
//     DOUT/DRDY .................... D12 (MISO)
//     DIN .......................... D11 (MOSI)
//     CS ........................... D10 (PIN_CS)
//     DRDY ......................... D2  (PIN_DRDY, an external-interrupt pin)
//     CLK .......................... GND (internal 4.096 MHz oscillator)
//     REFP0/REFN0 .................. unused (internal 2.048 V reference)
//     AIN0 ......................... HMC1021 OUT+
//     AIN1 ......................... HMC1021 OUT-
//
//   HMC1021 (single-axis AMR bridge, ~1.1 kOhm)
//     Vbridge ...................... 5V   (the bridge supply; the model's bridge_voltage = 5 V)
//     GND .......................... GND
//     OUT+/OUT- .................... AIN0/AIN1 (twisted pair; 10 nF across them near the ADC)
//     S/R+ ......................... the set/reset driver's output capacitor (below)
//     S/R- ......................... GND
//
//   Set/reset strap driver (optional; SETRESET_EVERY = 0 if not fitted). A complementary MOSFET
//   pair (e.g. IRF7105, or IRF7309) wired as an inverter between 5 V and GND, gates driven by
//   D7 (PIN_SR) through 100 Ohm; its output drives S/R+ through a 1 uF ceramic capacitor. Each edge
//   of PIN_SR sends one current pulse (about 0.5 A for a few microseconds) through the strap: the
//   inverter's output going high (PIN_SR high -> low) is a SET pulse, going low a RESET pulse
//   (SET_LEVEL below; swap it if your strap is wired the other way round). A 4.7 uF reservoir
//   capacitor on the pair's 5 V pin keeps the pulse off the ADC's supply.
//
// ---- Signal levels ------------------------------------------------------------------------------
//
//   HMC1021: about 1 mV/V/gauss = 10 V/V/T, so 5 mV per gauss (0.1 mT) at 5 V. The PGA gain of 32
//   gives a full scale of +-2.048 V / 32 = +-64 mV (+-12.8 gauss), one count = 7.63 nV. The frames
//   carry the bridge's own output voltage (input-referred: counts * volts_per_count), so the
//   magcilia Setup for this wiring has gain = 1 and bridge_voltage = 5 V.
//
// ---- Rates --------------------------------------------------------------------------------------
//
//   The ADS1220 converts continuously at DATA_RATE_HZ (normal mode: 20, 45, 90, 175, 330, 600 or
//   1000 SPS; its internal oscillator is within +-2 %, so the host's time axis is good to that).
//   Each sample is 4 bytes on the wire, a frame adds 28 bytes of header and CRC and about 2 of
//   COBS and delimiter: 32 samples/frame at 1000 SPS is about 4.9 kB/s, fine at 115200 baud
//   (11.5 kB/s). Above ~2 kB/s per 10 kbaud, raise BAUD (or use a native-USB board, where the baud
//   rate is ignored). If the link cannot keep up, the sample ring overflows: those samples are
//   lost on the device, and the host sees them as a gap in the sample index (counted as dropped).
//
// ---- What the sketch does -----------------------------------------------------------------------
//
//   * The DRDY interrupt reads each conversion into a ring of (sample index, counts).
//   * loop() takes samples from the ring into a frame of up to SAMPLES_PER_FRAME samples; a
//     frame ends early where the sample index jumps (ring overflow) or where a set/reset pulse
//     changed the strap's state, so that every frame has one state and consecutive samples.
//   * A full frame gets its header and CRC-32, is COBS-encoded into the transmit buffer and sent
//     as the serial port has room (never blocking, so no conversion is missed while sending).
//   * Every SETRESET_EVERY samples it pulses the strap (alternating set and reset), discards the
//     conversion disturbed by the pulse and restarts the ADC (START/SYNC), so that the first sample
//     flagged with the new state is a clean one.

#include <SPI.h>
#include <string.h>

// ---- configuration ------------------------------------------------------------------------------
const uint8_t PIN_CS = 10;
const uint8_t PIN_DRDY = 2;
const uint8_t PIN_SR = 7;
const uint8_t SET_LEVEL = LOW;            // PIN_SR level that gives a SET pulse (see wiring)
const uint32_t BAUD = 115200;
const uint16_t SAMPLES_PER_FRAME = 32;    // 32..64 keeps the overhead low and the latency short
const uint32_t SETRESET_EVERY = 0;        // samples between strap pulses (>= RING); 0: no driver
const uint32_t SPI_HZ = 2000000;          // ADS1220: SCLK period >= 150 ns

// ADS1220 registers (datasheet section 8.6)
//   reg0: MUX[7:4] = 0000 (AINP = AIN0, AINN = AIN1), GAIN[3:1] = 101 (32), PGA_BYPASS = 0
//   reg1: DR[7:5] = 110 (1000 SPS), MODE[4:3] = 00 (normal), CM = 1 (continuous), TS = 0, BCS = 0
//   reg2: VREF[7:6] = 00 (internal 2.048 V), 50/60[5:4] = 00 (no filter), PSW = 0, IDAC = 000
//   reg3: I1MUX = I2MUX = 000 (off), DRDYM = 0 (DRDY on its own pin only)
const uint8_t ADS_REG[4] = {0x0A, 0xC4, 0x00, 0x00};
const float DATA_RATE_HZ = 1000.0f;
const float VREF_V = 2.048f;
const float PGA_GAIN = 32.0f;
const float VOLTS_PER_COUNT = 2.0f * VREF_V / PGA_GAIN / 16777216.0f;  // 2 Vref / (G 2^24)

// ADS1220 commands
const uint8_t CMD_RESET = 0x06;
const uint8_t CMD_START = 0x08;
const uint8_t CMD_WREG = 0x40;            // 0100 rrnn: write nn+1 registers from rr

// ---- the protocol (docs/serial-protocol.md) -----------------------------------------------------
const uint8_t PROTOCOL_VERSION = 1;
const uint8_t FRAME_SAMPLES = 1;
const uint8_t FLAG_SETRESET_VALID = 0x01;
const uint8_t FLAG_SET = 0x02;
const uint8_t CHANNELS = 1;
const size_t HEADER_SIZE = 24;
const size_t FRAME_MAX = HEADER_SIZE + 4UL * SAMPLES_PER_FRAME * CHANNELS + 4;  // + CRC-32
const size_t WIRE_MAX = FRAME_MAX + FRAME_MAX / 254 + 2;                       // COBS + 0x00

static_assert(FRAME_MAX <= 16384, "a decoded frame must fit 16384 bytes");

uint8_t frame[FRAME_MAX];   // the frame being filled: header, counts, CRC
uint8_t wire[WIRE_MAX];     // the encoded frame being sent
size_t wire_len = 0;        // bytes in wire
size_t wire_sent = 0;       // bytes of wire already handed to Serial

uint16_t frame_n = 0;       // samples in the frame being filled
uint32_t frame_first = 0;   // index of its first sample
uint8_t frame_flags = 0;    // its set/reset flags
uint32_t sequence = 0;      // frames sent
bool frame_done = false;    // the frame is complete and waits for the transmit buffer

// ---- the sample ring, filled by the DRDY interrupt ----------------------------------------------
const uint8_t RING = 64;                  // a power of two; 64 ms of samples at 1000 SPS
volatile int32_t ring_value[RING];
volatile uint32_t ring_index[RING];
volatile uint8_t ring_head = 0;           // written by the interrupt
volatile uint8_t ring_tail = 0;           // written by loop()
volatile uint32_t samples_taken = 0;      // conversions read since start = next sample index

// ---- set/reset state ----------------------------------------------------------------------------
uint8_t state_flags = 0;                  // flags of samples from state_from on
uint32_t state_from = 0;
uint8_t old_flags = 0;                    // flags of samples before state_from
uint32_t next_pulse = SETRESET_EVERY;
bool next_is_set = true;

// ---- CRC-32 (zlib, ISO-HDLC): reflected polynomial 0xEDB88320, init and final XOR 0xFFFFFFFF ----
// Bitwise (no table, 2 KB of RAM matter on an Uno); check value: crc32("123456789") = 0xCBF43926.
uint32_t crc32(const uint8_t *data, size_t n) {
  uint32_t crc = 0xFFFFFFFFUL;
  while (n--) {
    crc ^= *data++;
    for (uint8_t k = 0; k < 8; k++) {
      crc = (crc >> 1) ^ (0xEDB88320UL & (0UL - (crc & 1UL)));
    }
  }
  return ~crc;
}

// ---- COBS (Cheshire & Baker 1999): out gets no 0x00; returns its length (<= n + n / 254 + 1) ----
size_t cobs_encode(const uint8_t *in, size_t n, uint8_t *out) {
  size_t code_at = 0;   // where the current block's code byte goes
  size_t o = 1;
  uint8_t code = 1;     // 1 + bytes in the current block
  for (size_t i = 0; i < n; i++) {
    if (in[i] != 0) {
      out[o++] = in[i];
      code++;
    }
    if (in[i] == 0 || code == 0xFF) {  // a zero, or a full block of 254 bytes: close the block
      out[code_at] = code;
      code = 1;
      code_at = o;
      if (in[i] == 0 || i + 1 < n) {
        o++;
      }
    }
  }
  out[code_at] = code;
  return o;
}

// ---- little-endian fields -----------------------------------------------------------------------
void put_u16(uint8_t *p, uint16_t x) {
  p[0] = (uint8_t)x;
  p[1] = (uint8_t)(x >> 8);
}

void put_u32(uint8_t *p, uint32_t x) {
  for (uint8_t k = 0; k < 4; k++) {
    p[k] = (uint8_t)(x >> (8 * k));
  }
}

void put_f32(uint8_t *p, float x) {  // IEEE 754 single precision, as float32 on the host
  uint32_t bits;
  memcpy(&bits, &x, 4);
  put_u32(p, bits);
}

// Header (offsets as in docs/serial-protocol.md), CRC, COBS and the 0x00 delimiter into wire[].
void encode_frame(uint16_t n) {
  frame[0] = PROTOCOL_VERSION;
  frame[1] = FRAME_SAMPLES;
  frame[2] = frame_flags;
  frame[3] = CHANNELS;
  put_u16(frame + 4, n);
  put_u16(frame + 6, 0);                  // reserved
  put_u32(frame + 8, sequence);
  put_u32(frame + 12, frame_first);
  put_f32(frame + 16, DATA_RATE_HZ);
  put_f32(frame + 20, VOLTS_PER_COUNT);
  size_t size = HEADER_SIZE + 4UL * n * CHANNELS;   // the counts are already in place
  put_u32(frame + size, crc32(frame, size));
  wire_len = cobs_encode(frame, size + 4, wire);
  wire[wire_len++] = 0x00;
  wire_sent = 0;
  sequence++;
}

// ---- the ADS1220 --------------------------------------------------------------------------------
const SPISettings ADS_SPI(SPI_HZ, MSBFIRST, SPI_MODE1);

void ads_command(uint8_t cmd) {
  SPI.beginTransaction(ADS_SPI);
  digitalWrite(PIN_CS, LOW);
  SPI.transfer(cmd);
  digitalWrite(PIN_CS, HIGH);
  SPI.endTransaction();
}

int32_t ads_read_raw() {  // 24-bit two's complement, MSB first; CS handled by the caller
  uint32_t x = 0;
  for (uint8_t k = 0; k < 3; k++) {
    x = (x << 8) | SPI.transfer(0x00);    // 0x00 is not an ADS1220 command
  }
  int32_t v = (int32_t)x;
  if (v & 0x800000L) {
    v -= 0x1000000L;                      // sign-extend 24 -> 32 bits
  }
  return v;
}

void on_drdy() {
  if (digitalRead(PIN_DRDY) == HIGH) {
    return;                               // a stale edge (after a pulse and START): no data
  }
  SPI.beginTransaction(ADS_SPI);
  digitalWrite(PIN_CS, LOW);
  int32_t v = ads_read_raw();
  digitalWrite(PIN_CS, HIGH);
  SPI.endTransaction();
  uint32_t index = samples_taken++;
  uint8_t next = (ring_head + 1) & (RING - 1);
  if (next == ring_tail) {
    return;                               // ring full: the sample is lost (a gap on the host)
  }
  ring_value[ring_head] = v;
  ring_index[ring_head] = index;
  ring_head = next;
}

// Pulse the strap, drop the disturbed conversion, restart the ADC; the new state holds from the
// next sample on.
void setreset_pulse(bool set) {
  SPI.beginTransaction(ADS_SPI);          // masks the DRDY interrupt (SPI.usingInterrupt)
  digitalWrite(PIN_SR, set ? SET_LEVEL : !SET_LEVEL);
  delayMicroseconds(50);                  // the pulse (a few us) and the bridge's settling
  digitalWrite(PIN_CS, LOW);
  if (digitalRead(PIN_DRDY) == LOW) {
    ads_read_raw();                       // a conversion that saw the pulse: discard it
  }
  SPI.transfer(CMD_START);                // restart: the next conversion is a clean one
  digitalWrite(PIN_CS, HIGH);
  noInterrupts();
  uint32_t from = samples_taken;
  interrupts();
  old_flags = state_flags;
  state_flags = FLAG_SETRESET_VALID | (set ? FLAG_SET : 0);
  state_from = from;
  SPI.endTransaction();
}

// ---- setup and loop -----------------------------------------------------------------------------
void setup() {
  Serial.begin(BAUD);
  pinMode(PIN_CS, OUTPUT);
  digitalWrite(PIN_CS, HIGH);
  pinMode(PIN_DRDY, INPUT_PULLUP);
  pinMode(PIN_SR, OUTPUT);
  digitalWrite(PIN_SR, !SET_LEVEL);
  SPI.begin();
  delay(5);
  ads_command(CMD_RESET);
  delay(1);
  SPI.beginTransaction(ADS_SPI);
  digitalWrite(PIN_CS, LOW);
  SPI.transfer(CMD_WREG | 0x03);          // registers 0..3
  for (uint8_t r = 0; r < 4; r++) {
    SPI.transfer(ADS_REG[r]);
  }
  digitalWrite(PIN_CS, HIGH);
  SPI.endTransaction();
  SPI.usingInterrupt(digitalPinToInterrupt(PIN_DRDY));
  attachInterrupt(digitalPinToInterrupt(PIN_DRDY), on_drdy, FALLING);
  if (SETRESET_EVERY > 0) {
    setreset_pulse(true);                 // start from a known state: set
    next_is_set = false;
  } else {
    ads_command(CMD_START);
  }
  Serial.write((uint8_t)0x00);            // a delimiter: the host starts on a frame boundary
}

void send_some() {  // hand the serial port what it can take now, never blocking
  if (wire_sent >= wire_len) {
    return;
  }
  int room = Serial.availableForWrite();
  if (room <= 0) {
    return;
  }
  size_t k = wire_len - wire_sent;
  if (k > (size_t)room) {
    k = (size_t)room;
  }
  Serial.write(wire + wire_sent, k);
  wire_sent += k;
}

void loop() {
  send_some();

  if (SETRESET_EVERY > 0) {
    noInterrupts();
    uint32_t taken = samples_taken;
    interrupts();
    if ((int32_t)(taken - next_pulse) >= 0) {
      setreset_pulse(next_is_set);
      next_is_set = !next_is_set;
      next_pulse = state_from + SETRESET_EVERY;
    }
  }

  // Move samples from the ring into the frame; a frame ends when full, at a gap in the sample
  // index, or where the set/reset state changes.
  while (!frame_done && ring_tail != ring_head) {
    uint8_t t = ring_tail;
    uint32_t index = ring_index[t];
    uint8_t flags = ((int32_t)(index - state_from) >= 0) ? state_flags : old_flags;
    if (frame_n > 0 && (index != frame_first + frame_n || flags != frame_flags)) {
      frame_done = true;                  // this sample starts the next frame
      break;
    }
    if (frame_n == 0) {
      frame_first = index;
      frame_flags = flags;
    }
    put_u32(frame + HEADER_SIZE + 4UL * frame_n, (uint32_t)ring_value[t]);
    frame_n++;
    ring_tail = (t + 1) & (RING - 1);
    frame_done = frame_n == SAMPLES_PER_FRAME;
  }

  // Encode a complete frame once the previous one has left (meanwhile the ring keeps filling).
  if (frame_done && wire_sent >= wire_len) {
    encode_frame(frame_n);
    frame_n = 0;
    frame_done = false;
  }
}
