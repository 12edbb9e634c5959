// hapticfx solenoid firmware, protocol version 1 (see docs/solenoid.md).
//
// Arduino Uno driving a push-pull solenoid (JF-0826B, 12 V) through a
// logic-level MOSFET (gate on SOLENOID_PIN, flyback diode across the coil).
// One ASCII command per line, one reply line per command; the host starts
// every exchange (PING first), the board never talks on its own.
//
//   PING               -> PONG 1 hapticfx-solenoid/1.0
//   STATUS             -> STATUS on=.. used_ms=.. budget_ms=.. max_on_ms=.. duty_permille=.. window_ms=.. fired=.. refused=..
//   FIRE <ms> <duty>   -> OK FIRE <ms> <duty>   (duty 0..255 = analogWrite value)
//   STOP               -> OK STOP
//   refused            -> ERR <SYNTAX|RANGE|LIMIT|BUSY|DUTY|TOOLONG> <text>
//
// Thermal protection lives here as well as on the host, so a buggy or
// hostile host cannot cook the coil: no pulse longer than MAX_ON_MS (nor a run
// of pulses each less than PULSE_GAP_MS after the last, gaps counted as on), at most
// DUTY_PERMILLE of WINDOW_MS on, booked in DUTY_SLOTS + 1 slots (the same
// book-keeping as hapticfx_solenoid.protocol.DutyWindow). A watchdog resets
// the board (coil off) if the loop ever stalls. Change the limits for your
// coil here and in nothing else: the host reads them with STATUS.

#ifdef __AVR__
#include <avr/wdt.h>
#endif

const uint8_t SOLENOID_PIN = 9;          // PWM pin (Timer1, ~490 Hz)
const unsigned long BAUD = 115200;
const uint16_t MAX_ON_MS = 100;
const uint16_t PULSE_GAP_MS = 10;        // off for less than this between pulses: the same pulse
const uint16_t DUTY_PERMILLE = 250;
const uint16_t WINDOW_MS = 10000;
const uint8_t DUTY_SLOTS = 10;
const uint8_t MAX_LINE = 32;
const char FIRMWARE_ID[] = "hapticfx-solenoid/1.0";

const uint16_t BUDGET_MS = (uint32_t)WINDOW_MS * DUTY_PERMILLE / 1000;
const uint16_t SLOT_MS = WINDOW_MS / DUTY_SLOTS;

uint16_t ring[DUTY_SLOTS + 1];
unsigned long slotIndex = 0;             // absolute slot number of ring's current slot
bool pulseOn = false;
unsigned long pulseStart = 0;
uint16_t pulseMs = 0;
unsigned long runStart = 0;              // when the current run of pulses began
bool firedOnce = false;
unsigned long fired = 0;
unsigned long refused = 0;

char line[MAX_LINE + 1];
uint8_t lineLength = 0;
bool lineTooLong = false;

void coilOff() {
  analogWrite(SOLENOID_PIN, 0);
  digitalWrite(SOLENOID_PIN, LOW);
  pulseOn = false;
}

void updatePulse(unsigned long now) {
  if (pulseOn && now - pulseStart >= pulseMs) coilOff();
}

void advanceSlots(unsigned long now) {
  unsigned long current = now / SLOT_MS;
  if (current - slotIndex > DUTY_SLOTS) {
    for (uint8_t i = 0; i <= DUTY_SLOTS; i++) ring[i] = 0;
    slotIndex = current;
  }
  while (slotIndex < current) {
    slotIndex++;
    ring[slotIndex % (DUTY_SLOTS + 1)] = 0;
  }
}

uint16_t usedMs(unsigned long now) {
  advanceSlots(now);
  uint32_t sum = 0;
  for (uint8_t i = 0; i <= DUTY_SLOTS; i++) sum += ring[i];
  return sum > 0xFFFF ? 0xFFFF : (uint16_t)sum;
}

uint16_t availableMs(unsigned long now) {
  uint16_t used = usedMs(now);
  return used >= BUDGET_MS ? 0 : BUDGET_MS - used;
}

void refuse(const char *code, const char *text) {
  refused++;
  Serial.print("ERR ");
  Serial.print(code);
  Serial.print(" ");
  Serial.println(text);
}

void refuseNumber(const char *code, const char *before, unsigned long value, const char *after) {
  refused++;
  Serial.print("ERR ");
  Serial.print(code);
  Serial.print(" ");
  Serial.print(before);
  Serial.print(value);
  Serial.println(after);
}

// A decimal of 1..5 digits; false for anything else.
bool parseNumber(const char *text, unsigned long *value) {
  uint8_t digits = 0;
  unsigned long v = 0;
  for (; *text; text++, digits++) {
    if (*text < '0' || *text > '9' || digits >= 5) return false;
    v = v * 10 + (*text - '0');
  }
  *value = v;
  return digits > 0;
}

// Splits line in place at spaces; returns the number of words (at most max).
uint8_t splitWords(char *text, char **words, uint8_t max) {
  uint8_t count = 0;
  while (*text) {
    while (*text == ' ') *text++ = '\0';
    if (!*text) break;
    if (count == max) return max + 1;
    words[count++] = text;
    while (*text && *text != ' ') text++;
  }
  return count;
}

void fire(char **args, uint8_t count, unsigned long now) {
  unsigned long ms, duty;
  if (count != 2 || !parseNumber(args[0], &ms) || !parseNumber(args[1], &duty)) {
    refuse("SYNTAX", "usage FIRE <ms> <duty>");
    return;
  }
  if (ms < 1 || duty > 255) {
    refuse("RANGE", "ms >= 1, duty 0..255");
    return;
  }
  if (ms > MAX_ON_MS) {
    refuseNumber("LIMIT", "max on-time ", MAX_ON_MS, " ms");
    return;
  }
  if (pulseOn) {
    refuseNumber("BUSY", "pulse on for ", pulseMs - (now - pulseStart), " ms");
    return;
  }
  // the last pulse's planned end (a STOP may have ended it sooner: counting to its plan is the stricter)
  bool run = firedOnce && (long)(now - (pulseStart + pulseMs)) < (long)PULSE_GAP_MS;
  if (run) {
    unsigned long used = now - runStart;
    unsigned long left = used >= MAX_ON_MS ? 0 : MAX_ON_MS - used;
    if (ms > left) {
      refuseNumber("LIMIT", "", left, " ms on-time left in this run");
      return;
    }
  }
  uint16_t available = availableMs(now);
  if (ms > available) {
    refuseNumber("DUTY", "", available, " ms left in window");
    return;
  }
  advanceSlots(now);
  ring[slotIndex % (DUTY_SLOTS + 1)] += ms;
  if (!run) runStart = now;
  firedOnce = true;
  pulseOn = true;
  pulseStart = now;
  pulseMs = ms;
  fired++;
  analogWrite(SOLENOID_PIN, duty);
  Serial.print("OK FIRE ");
  Serial.print(ms);
  Serial.print(" ");
  Serial.println(duty);
}

void status(unsigned long now) {
  Serial.print("STATUS on=");
  Serial.print(pulseOn ? 1 : 0);
  Serial.print(" used_ms=");
  Serial.print(usedMs(now));
  Serial.print(" budget_ms=");
  Serial.print(BUDGET_MS);
  Serial.print(" max_on_ms=");
  Serial.print(MAX_ON_MS);
  Serial.print(" duty_permille=");
  Serial.print(DUTY_PERMILLE);
  Serial.print(" window_ms=");
  Serial.print(WINDOW_MS);
  Serial.print(" fired=");
  Serial.print(fired);
  Serial.print(" refused=");
  Serial.println(refused);
}

void handleLine(unsigned long now) {
  char *words[4];
  uint8_t count = splitWords(line, words, 3);
  if (count == 0) return;
  const char *command = words[0];
  uint8_t nargs = count > 3 ? 3 : count - 1;
  if (count <= 3 && nargs == 0 && strcmp(command, "PING") == 0) {
    Serial.print("PONG 1 ");
    Serial.println(FIRMWARE_ID);
  } else if (count <= 3 && nargs == 0 && strcmp(command, "STATUS") == 0) {
    status(now);
  } else if (count <= 3 && nargs == 0 && strcmp(command, "STOP") == 0) {
    coilOff();
    Serial.println("OK STOP");
  } else if (strcmp(command, "FIRE") == 0) {
    fire(words + 1, count > 3 ? 3 : nargs, now);
  } else {
    refuse("SYNTAX", "unknown command");
  }
}

void setup() {
  pinMode(SOLENOID_PIN, OUTPUT);
  coilOff();
  Serial.begin(BAUD);
#ifdef __AVR__
  wdt_enable(WDTO_250MS);
#endif
}

void loop() {
#ifdef __AVR__
  wdt_reset();
#endif
  unsigned long now = millis();
  updatePulse(now);
  while (Serial.available() > 0) {
    char c = Serial.read();
    if (c == '\r') continue;
    if (c == '\n') {
      now = millis();
      updatePulse(now);
      if (lineTooLong) {
        refuseNumber("TOOLONG", "line longer than ", MAX_LINE, " bytes");
      } else {
        line[lineLength] = '\0';
        handleLine(now);
      }
      lineLength = 0;
      lineTooLong = false;
    } else if (lineLength < MAX_LINE) {
      line[lineLength++] = c;
    } else {
      lineTooLong = true;
    }
  }
}
