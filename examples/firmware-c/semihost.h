/* ARM semihosting (bkpt 0xAB), the few calls the firmware needs: the host
 * side is QEMU's -semihosting (files in its working directory, its stdout). */
#ifndef SEMIHOST_H
#define SEMIHOST_H
#include <stddef.h>
#include <stdint.h>

/* A file for writing ("wb"), or -1. */
int sh_create(const char *path);
/* Write `len` bytes at byte `offset`; 0 on success. */
int sh_write_at(int fd, uint32_t offset, const void *bytes, size_t len);
int sh_close(int fd);
/* A NUL-terminated string to QEMU's stdout. */
void sh_puts(const char *s);
/* "name=value" with an unsigned decimal value, then a space or newline. */
void sh_put_field(const char *name, uint32_t value, char end);
/* Stop QEMU with this exit status. */
void sh_exit(int status) __attribute__((noreturn));
#endif
