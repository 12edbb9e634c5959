// hapticfx accelerometer board: an Arduino (Uno/Nano, 16 MHz) sampling a GY-61
// (ADXL335, ratiometric analog outputs) on A0/A1/A2 at 1 kHz and streaming raw
// ADC counts over serial at 500000 baud.
//
// Wiring: GY-61 VCC -> 3.3V, GND -> GND, X -> A0, Y -> A1, Z -> A2,
//         Arduino 3.3V -> AREF (so that full scale is the sensor's supply).
//
// Line protocol (ASCII, '\n'-terminated; see docs/data.md and
// hapticfx/board/protocol.py). The host speaks first:
//   HELLO  -> HAPTICFX-ACCEL 1 rate_hz=1000 sensor=ADXL335 board=GY-61 adc_bits=10 zero=512,512,512 counts_per_g=102.4,102.4,102.4
//   START  -> OK START, then one line per sample: seq,x,y,z  (seq modulo 65536)
//   STOP   -> OK STOP
//   other  -> ERR unknown command <text>
// ADXL335 at 3.3 V: 0 g at Vs/2 (512 counts), 330 mV/g = 102.4 counts/g. Calibrate
// zero and counts_per_g per axis for your part and edit the constants below.

const unsigned long BAUD = 500000;
const unsigned long PERIOD_US = 1000;  // 1 kHz
const char HELLO_REPLY[] =
    "HAPTICFX-ACCEL 1 rate_hz=1000 sensor=ADXL335 board=GY-61 adc_bits=10 "
    "zero=512,512,512 counts_per_g=102.4,102.4,102.4";

bool streaming = false;
unsigned int seq = 0;
unsigned long next_us = 0;
char cmd[32];
byte cmd_len = 0;

void setup() {
  analogReference(EXTERNAL);
  // ADC prescaler 16 (1 MHz ADC clock): ~16 us per conversion, so three
  // channels fit well inside the 1 ms period.
  ADCSRA = (ADCSRA & ~0x07) | 0x04;
  Serial.begin(BAUD);
}

void handle(const char *c) {
  if (strcmp(c, "HELLO") == 0) {
    Serial.println(HELLO_REPLY);
  } else if (strcmp(c, "START") == 0) {
    Serial.println("OK START");
    streaming = true;
    seq = 0;
    next_us = micros();
  } else if (strcmp(c, "STOP") == 0) {
    streaming = false;
    Serial.println("OK STOP");
  } else if (c[0] != '\0') {
    Serial.print("ERR unknown command ");
    Serial.println(c);
  }
}

void readCommands() {
  while (Serial.available() > 0) {
    char ch = (char)Serial.read();
    if (ch == '\r') continue;
    if (ch == '\n') {
      cmd[cmd_len] = '\0';
      handle(cmd);
      cmd_len = 0;
    } else if (cmd_len < sizeof(cmd) - 1) {
      cmd[cmd_len++] = ch;
    }
  }
}

void loop() {
  readCommands();
  if (!streaming) return;
  unsigned long now = micros();
  if ((long)(now - next_us) < 0) return;
  next_us += PERIOD_US;
  // If the loop fell behind (serial buffer full), skip the missed slots: the
  // sequence number still counts them, so the host sees the gap.
  if ((long)(now - next_us) > (long)PERIOD_US) {
    unsigned long missed = (now - next_us) / PERIOD_US;
    seq += missed;
    next_us += missed * PERIOD_US;
  }
  int x = analogRead(A0);
  int y = analogRead(A1);
  int z = analogRead(A2);
  // "seq,x,y,z\n": at most 21 bytes, 21 kB/s at 1 kHz; 500000 baud carries 50 kB/s.
  Serial.print(seq);
  Serial.print(',');
  Serial.print(x);
  Serial.print(',');
  Serial.print(y);
  Serial.print(',');
  Serial.println(z);
  seq++;
}
