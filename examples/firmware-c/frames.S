/* The pair and the host's expected bytes, from the fixtures (FIXTURES=DIR
 * in the Makefile: prev.gray, next.gray, expected.rgb). */
  .section .rodata.frames, "a"
  .balign 4
  .global rf_prev, rf_next, rf_expected
rf_prev:
  .incbin "prev.gray"
  .balign 4
rf_next:
  .incbin "next.gray"
  .balign 4
rf_expected:
  .incbin "expected.rgb"
  .section .note.GNU-stack, "", %progbits
