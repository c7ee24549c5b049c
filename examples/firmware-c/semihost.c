#include "semihost.h"

#include <string.h>

enum { SYS_OPEN = 0x01, SYS_CLOSE = 0x02, SYS_WRITE0 = 0x04, SYS_WRITE = 0x05, SYS_SEEK = 0x0A,
       SYS_EXIT_EXTENDED = 0x20 };

static int call(int op, const void *arg) {
  register int r0 __asm__("r0") = op;
  register const void *r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

int sh_create(const char *path) {
  const uintptr_t args[3] = {(uintptr_t)path, 5 /* "wb" */, strlen(path)};
  return call(SYS_OPEN, args);
}

int sh_write_at(int fd, uint32_t offset, const void *bytes, size_t len) {
  const uintptr_t seek[2] = {(uintptr_t)fd, offset};
  const uintptr_t write[3] = {(uintptr_t)fd, (uintptr_t)bytes, len};
  return call(SYS_SEEK, seek) != 0 || call(SYS_WRITE, write) != 0;
}

int sh_close(int fd) {
  const uintptr_t args[1] = {(uintptr_t)fd};
  return call(SYS_CLOSE, args);
}

void sh_puts(const char *s) { call(SYS_WRITE0, s); }

void sh_put_field(const char *name, uint32_t value, char end) {
  char digits[16], *p = digits + sizeof digits;
  *--p = '\0';
  *--p = end;
  do *--p = (char)('0' + value % 10); while ((value /= 10) != 0);
  *--p = '=';
  sh_puts(name);
  sh_puts(p);
}

void sh_exit(int status) {
  const uintptr_t args[2] = {0x20026 /* ADP_Stopped_ApplicationExit */, (uintptr_t)status};
  for (;;) call(SYS_EXIT_EXTENDED, args);
}
