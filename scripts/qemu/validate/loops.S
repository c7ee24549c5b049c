/* Short instruction sequences whose cycle counts the Cortex-M4 Technical
 * Reference Manual publishes (its load/store pairing examples and rules,
 * its instruction and FPU tables), for validating the cycle model
 * (scripts/qemu/cycles.py) against them: scripts/qemu/validate-model.
 *
 * Every test is a function that runs its sequence N times. The sequence
 * lies between the labels <test>_start and <test>_stop, which the
 * instruction counter takes as its window; what sets the registers up
 * (outside the window) ends in a NOP, so no sequence is pipelined with or
 * stalled by what comes before it. Built for the M4F (mps2-an386) and the
 * M33 (mps2-an505): CODE and RAM are the board's code and data addresses.
 * Exits through semihosting with 0. */
        .syntax unified
        .thumb

        .equ N, 100
        .equ BUF, RAM               @ 256 bytes of scratch: BUF[0] = BUF[1] = BUF
        .equ STACK_TOP, RAM + 0x10000

        .text
        .word STACK_TOP             @ the vector table: stack, reset
        .word reset

        .global reset
        .thumb_func
reset:
        ldr r0, =0xE000ED88         @ CPACR: CP10 and CP11 (the FPU) on
        ldr r1, [r0]
        orr r1, r1, #(0xF << 20)
        str r1, [r0]
        dsb
        isb
        ldr r0, =BUF
        str r0, [r0]
        str r0, [r0, #4]
        bl ldr_ldr
        bl ldr_str_imm
        bl ldr_str_reg
        bl ldr_ldr_ldr
        bl ldr_chain
        bl str_imm
        bl str_ldr
        bl alu_ldr
        bl ldrd
        bl ldm3
        bl stm8
        bl mul_smlal
        bl mla_mls
        bl branch
        bl mac_loop
        bl vadd_vmul
        bl vmla
        bl vdiv
        bl vsqrt
        bl vldr_vldr
        bl vldm4
        movs r0, #0x18              @ SYS_EXIT, ADP_Stopped_ApplicationExit
        ldr r1, =0x20026
        bkpt 0xab
        .ltorg

/* BEGIN name: the function and its loop; then the set-up; then MID name:
 * the window opens; then the sequence; then END name. */
        .macro BEGIN name
        .thumb_func
        .global \name
\name:
        push {r4-r11, lr}
        mov r11, #N
1:
        .endm
        .macro MID name
        nop
        .global \name\()_start
\name\()_start:
        .endm
        .macro END name
        .global \name\()_stop
\name\()_stop:
        nop
        subs r11, r11, #1
        bne 1b
        pop {r4-r11, pc}
        .ltorg
        .endm

        BEGIN ldr_ldr               @ TRM: "LDR R0,[R1]; LDR R1,[R2]": 3 cycles
        ldr r1, =BUF
        ldr r2, =BUF
        MID ldr_ldr
        ldr r0, [r1]
        ldr r1, [r2]
        END ldr_ldr

        BEGIN ldr_str_imm           @ TRM: "LDR R0,[R1,R2]; STR R0,[R3,#20]": 3
        ldr r1, =BUF
        movs r2, #0
        ldr r3, =BUF + 64
        MID ldr_str_imm
        ldr r0, [r1, r2]
        str r0, [r3, #20]
        END ldr_str_imm

        BEGIN ldr_str_reg           @ TRM: "LDR R0,[R1,R2]; STR R1,[R3,R2]": 3
        ldr r1, =BUF
        movs r2, #0
        ldr r3, =BUF + 64
        MID ldr_str_reg
        ldr r0, [r1, r2]
        str r1, [r3, r2]
        END ldr_str_reg

        BEGIN ldr_ldr_ldr           @ TRM: "LDR R0,[R1,R5]; LDR R1,[R2]; LDR R2,[R3,#4]": 4
        ldr r1, =BUF
        ldr r2, =BUF
        ldr r3, =BUF
        movs r5, #0
        MID ldr_ldr_ldr
        ldr r0, [r1, r5]
        ldr r1, [r2]
        ldr r2, [r3, #4]
        END ldr_ldr_ldr

        BEGIN ldr_chain             @ TRM: not pipelined when the first's result is the address: 2 + 2
        ldr r1, =BUF
        MID ldr_chain
        ldr r1, [r1]
        ldr r0, [r1]
        END ldr_chain

        BEGIN str_imm               @ TRM: "STR Rx,[Ry,#imm] is always one cycle"
        ldr r1, =BUF + 64
        MID str_imm
        str r0, [r1, #4]
        END str_imm

        BEGIN str_ldr               @ TRM: STR 1; nothing pipelines after a store: LDR 2
        ldr r1, =BUF + 64
        ldr r3, =BUF
        MID str_ldr
        str r0, [r1, #4]
        ldr r2, [r3]
        END str_ldr

        BEGIN alu_ldr               @ TRM: ADD 1, LDR 2, + 1: its address from the ADD
        ldr r2, =BUF
        MID alu_ldr
        add r1, r2, #4
        ldr r0, [r1]
        END alu_ldr

        BEGIN ldrd                  @ TRM: LDRD 3
        ldr r1, =BUF
        MID ldrd
        ldrd r4, r5, [r1]
        END ldrd

        BEGIN ldm3                  @ TRM: LDM 1 + N, N = 3
        ldr r1, =BUF
        MID ldm3
        ldm r1, {r4, r5, r6}
        END ldm3

        BEGIN stm8                  @ TRM: STM 1 + N, N = 8
        ldr r1, =BUF + 64
        MID stm8
        stm r1, {r2-r9}
        END stm8

        BEGIN mul_smlal             @ TRM table: MUL 1, SMLAL 1
        movs r1, #3
        movs r2, #5
        MID mul_smlal
        mul r0, r1, r2
        smlal r4, r5, r1, r2
        END mul_smlal

        BEGIN mla_mls               @ TRM table (TI SWCU192): MLA 1, MLS 1
        movs r1, #3
        movs r2, #5
        MID mla_mls
        mla r0, r1, r2, r0
        mls r3, r1, r2, r3
        END mla_mls

        BEGIN branch                @ TRM table: B 1 + P, P = 1 to 3
        MID branch
        b 2f
        nop
2:
        END branch

        BEGIN mac_loop              @ the rules over a dot-product loop, 4 iterations
        ldr r0, =BUF
        ldr r1, =BUF
        movs r2, #16
        MID mac_loop
3:      ldr r3, [r0, r2]            @ 2 (after the loop's branch: not pipelined)
        ldr r4, [r1, r2]            @ 1 (pipelined)
        mla r5, r3, r4, r5          @ 1
        subs r2, r2, #4             @ 1
        bne 3b                      @ 1 + P taken (3 times), 1 not taken
        END mac_loop

        BEGIN vadd_vmul             @ FPU table: VADD 1, VMUL 1
        MID vadd_vmul
        vadd.f32 s0, s1, s2
        vmul.f32 s3, s4, s5
        END vadd_vmul

        BEGIN vmla                  @ FPU table: VMLA 3
        MID vmla
        vmla.f32 s0, s1, s2
        END vmla

        BEGIN vdiv                  @ FPU table: VDIV 14
        vmov.f32 s2, #1.0
        MID vdiv
        vdiv.f32 s0, s1, s2
        END vdiv

        BEGIN vsqrt                 @ FPU table: VSQRT 14
        MID vsqrt
        vsqrt.f32 s0, s1
        END vsqrt

        BEGIN vldr_vldr             @ FPU table: VLDR 2 (load single float); the pair 3
        ldr r1, =BUF
        MID vldr_vldr
        vldr s0, [r1]
        vldr s1, [r1, #4]
        END vldr_vldr

        BEGIN vldm4                 @ FPU table: VLDM 1 + N, N = 4
        ldr r1, =BUF
        MID vldm4
        vldmia r1, {s0-s3}
        END vldm4
