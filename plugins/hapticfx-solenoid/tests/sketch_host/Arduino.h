// A host (Linux) stand-in for the few Arduino APIs solenoid.ino uses, so the
// real sketch source can be compiled with g++ and driven through pipes by the
// tests. Not an Arduino: stdin/stdout play the serial port, and the clock is
// set by the test with lines "#T <ms>" (consumed here, never seen by the sketch).
// Every analogWrite is logged to stderr as "PWM <pin> <value> <ms>".
#pragma once
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <type_traits>

#define OUTPUT 1
#define LOW 0
#define HIGH 1

unsigned long millis();
void pinMode(uint8_t pin, uint8_t mode);
void digitalWrite(uint8_t pin, uint8_t value);
void analogWrite(uint8_t pin, int value);

class HostSerial {
 public:
  void begin(unsigned long) {}
  int available();
  int read();
  void print(const char *text) { fputs(text, stdout); }
  template <typename T, typename = std::enable_if_t<std::is_integral_v<T>>>
  void print(T value) { printf("%lld", (long long)value); }
  template <typename T>
  void println(T value) { print(value); fputs("\r\n", stdout); fflush(stdout); }
};

extern HostSerial Serial;
