// Runs the sketch's setup() and loop() on the host (see Arduino.h here).
#include "Arduino.h"
#include <stdlib.h>
#include <string>

HostSerial Serial;
static unsigned long fake_now = 0;
static std::string pending;
static size_t pending_pos = 0;

unsigned long millis() { return fake_now; }
void pinMode(uint8_t, uint8_t) {}
void digitalWrite(uint8_t, uint8_t) {}
void analogWrite(uint8_t pin, int value) { fprintf(stderr, "PWM %d %d %lu\n", pin, value, fake_now); }

int HostSerial::available() {
  while (pending_pos >= pending.size()) {
    char buf[512];
    if (!fgets(buf, sizeof buf, stdin)) exit(0);
    if (strncmp(buf, "#T ", 3) == 0) {
      fake_now = strtoul(buf + 3, nullptr, 10);
      continue;
    }
    pending = buf;
    pending_pos = 0;
  }
  return (int)(pending.size() - pending_pos);
}

int HostSerial::read() { return available() > 0 ? (unsigned char)pending[pending_pos++] : -1; }

void setup();
void loop();

int main() {
  setup();
  for (;;) loop();
}
