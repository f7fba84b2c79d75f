//! Thumb instructions decoded from their encodings (ARMv7-M ARM, A5 and A7.7): their length,
//! and how they move SP, so a translated block's deepest SP is known before it runs, not
//! only the SP it starts with (the stack high-water mark per task would miss the frame of a
//! leaf function whose push and pop fall in one block).
//!
//! Decoded: PUSH/POP (T1, T2, T3), STR/LDR with SP write-back, STRD/LDRD with SP
//! write-back, ADD/SUB SP, SP, #imm (T1, T2, T3, T4 encodings of `add sp` / `sub sp`).
//! Everything else leaves SP alone, except the instructions that set SP from a register
//! (`mov sp, rN`, `add sp, rN`, ADD/SUB SP with a register operand, MSR MSP/PSP, LDM with
//! SP in the list), whose effect is unknown here.

/// Bytes of the Thumb instruction whose first halfword is `hw`: 32-bit encodings start with
/// 0b11101, 0b11110 or 0b11111.
pub fn length(hw: u16) -> usize {
    if hw >> 11 >= 0b11101 {
        4
    } else {
        2
    }
}

/// What one instruction does to SP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpChange {
    /// Leaves SP alone.
    None,
    /// Adds this many bytes (negative: the stack grows).
    By(i32),
    /// Sets SP to a value not known from the encoding.
    Unknown,
}

/// The effect of the instruction whose halfwords are `hw1` and, for 32-bit encodings,
/// `hw2` (ignored for 16-bit ones).
pub fn sp_change(hw1: u16, hw2: u16) -> SpChange {
    if length(hw1) == 2 {
        narrow(hw1)
    } else {
        wide(hw1, hw2)
    }
}

fn narrow(hw: u16) -> SpChange {
    let regs = |extra: u16| (hw & 0xFF).count_ones() as i32 + i32::from(extra);
    match hw {
        // PUSH T1: 1011 010M list.
        _ if hw & 0xFE00 == 0xB400 => SpChange::By(-4 * regs((hw >> 8) & 1)),
        // POP T1: 1011 110P list.
        _ if hw & 0xFE00 == 0xBC00 => SpChange::By(4 * regs((hw >> 8) & 1)),
        // ADD SP, SP, #imm7 * 4 (T2) / SUB SP, SP, #imm7 * 4 (T1).
        _ if hw & 0xFF80 == 0xB000 => SpChange::By(4 * i32::from(hw & 0x7F)),
        _ if hw & 0xFF80 == 0xB080 => SpChange::By(-4 * i32::from(hw & 0x7F)),
        // MOV SP, Rm (T1: 0100 0110 D mmmm ddd, D:ddd = 13) and ADD SP, Rm (0100 0100 ...).
        _ if hw & 0xFF87 == 0x4685 || hw & 0xFF87 == 0x4485 => SpChange::Unknown,
        _ => SpChange::None,
    }
}

fn wide(hw1: u16, hw2: u16) -> SpChange {
    let rn_sp = hw1 & 0xF == 0xD;
    let rd_sp = (hw2 >> 8) & 0xF == 0xD;
    match hw1 {
        // STMDB SP!, list (PUSH T2) / LDMIA SP!, list (POP T2).
        0xE92D => SpChange::By(-4 * hw2.count_ones() as i32),
        0xE8BD if hw2 & 0x2000 != 0 => SpChange::Unknown,
        0xE8BD => SpChange::By(4 * hw2.count_ones() as i32),
        // STR Rt, [SP, #+-imm8]! / LDR Rt, [SP], #+-imm8 (T4; PUSH T3 and POP T3 are the
        // 4-byte cases): 1 P U W imm8 in the second halfword, write-back when W.
        0xF84D | 0xF85D if hw2 & 0x0900 == 0x0900 => {
            let imm = i32::from(hw2 & 0xFF);
            let load_into_sp = hw1 == 0xF85D && hw2 >> 12 == 0xD;
            if load_into_sp {
                SpChange::Unknown
            } else if hw2 & 0x0200 != 0 {
                SpChange::By(imm)
            } else {
                SpChange::By(-imm)
            }
        }
        // STRD/LDRD Rt, Rt2, [SP, #+-imm8 * 4] with write-back: 1110 100P U1WL 1101, W set.
        _ if hw1 & 0xFE6F == 0xE86D => {
            let imm = 4 * i32::from(hw2 & 0xFF);
            SpChange::By(if hw1 & 0x0080 != 0 { imm } else { -imm })
        }
        // ADD/SUB (immediate) with Rd = Rn = SP: T3/T2 (modified immediate, 11110 i 0 1000/1101
        // S 1101) and T4/T3 (plain 12-bit, 11110 i 1 0000/1010 0 1101).
        _ if hw1 & 0xF800 == 0xF000 && hw2 & 0x8000 == 0 && rn_sp && rd_sp => {
            let i = u32::from((hw1 >> 10) & 1);
            let imm12 = (i << 11) | (u32::from((hw2 >> 12) & 7) << 8) | u32::from(hw2 & 0xFF);
            match hw1 & 0xFBE0 {
                0xF100 => SpChange::By(thumb_expand_imm(imm12) as i32),
                0xF1A0 => SpChange::By(-(thumb_expand_imm(imm12) as i32)),
                0xF200 if hw1 & 0x10 == 0 => SpChange::By(imm12 as i32),
                0xF2A0 if hw1 & 0x10 == 0 => SpChange::By(-(imm12 as i32)),
                _ => SpChange::None,
            }
        }
        // ADD/SUB (register) with Rd = SP: 1110 1011 000S / 1101 Rn, Rd in the second
        // halfword; MSR to MSP or PSP (1111 0011 1000 Rn, SYSm 8 or 9).
        _ if (hw1 & 0xFFE0 == 0xEB00 || hw1 & 0xFFE0 == 0xEBA0) && rd_sp => SpChange::Unknown,
        _ if hw1 & 0xFFF0 == 0xF380 && matches!(hw2 & 0xFF, 8 | 9) => SpChange::Unknown,
        _ => SpChange::None,
    }
}

/// ThumbExpandImm (A5.3.2) of a 12-bit modified immediate.
fn thumb_expand_imm(imm12: u32) -> u32 {
    let imm8 = imm12 & 0xFF;
    if imm12 >> 10 == 0 {
        match (imm12 >> 8) & 3 {
            0 => imm8,
            1 => imm8 * 0x0001_0001,
            2 => imm8 * 0x0100_0100,
            _ => imm8 * 0x0101_0101,
        }
    } else {
        (0x80 | (imm12 & 0x7F)).rotate_right(imm12 >> 7)
    }
}

/// The deepest SP of straight-line `code` below SP at its start (bytes), the instructions
/// decoded in order; the scan stops at an instruction whose effect is unknown.
pub fn deepest_below_start(code: &[u8]) -> u32 {
    let (mut sp, mut lowest) = (0i64, 0i64);
    let half = |i: usize| {
        code.get(i..i + 2)
            .map_or(0, |b| u16::from_le_bytes([b[0], b[1]]))
    };
    let mut i = 0;
    while i + 1 < code.len() {
        let hw1 = half(i);
        match sp_change(hw1, half(i + 2)) {
            SpChange::None => {}
            SpChange::By(d) => sp += i64::from(d),
            SpChange::Unknown => break,
        }
        lowest = lowest.min(sp);
        i += length(hw1);
    }
    (-lowest) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths() {
        assert_eq!(length(0xBF30), 2, "wfi");
        assert_eq!(length(0xF000), 4, "bl, first half");
        assert_eq!(length(0xE92D), 4, "push.w");
        assert_eq!(length(0xE7FE), 2, "b .");
    }

    /// Encodings from `llvm-mc --triple=thumbv7m-none-eabi -show-encoding`.
    #[test]
    fn encodings_as_llvm_assembles_them() {
        let by = |hw1, hw2| sp_change(hw1, hw2);
        assert_eq!(
            by(0xB5F0, 0),
            SpChange::By(-20),
            "push {{r4, r5, r6, r7, lr}}"
        );
        assert_eq!(by(0xB580, 0), SpChange::By(-8), "push {{r7, lr}}");
        assert_eq!(
            by(0xBDF0, 0),
            SpChange::By(20),
            "pop {{r4, r5, r6, r7, pc}}"
        );
        assert_eq!(by(0xB084, 0), SpChange::By(-16), "sub sp, #16");
        assert_eq!(by(0xB004, 0), SpChange::By(16), "add sp, #16");
        assert_eq!(
            by(0xE92D, 0x0F00),
            SpChange::By(-16),
            "push.w {{r8, r9, r10, r11}}"
        );
        assert_eq!(
            by(0xE8BD, 0x0F00),
            SpChange::By(16),
            "pop.w {{r8, r9, r10, r11}}"
        );
        assert_eq!(by(0xE8BD, 0x8FF0), SpChange::By(36), "pop.w {{r4-r11, pc}}");
        assert_eq!(by(0xF84D, 0xBD04), SpChange::By(-4), "str r11, [sp, #-4]!");
        assert_eq!(by(0xF85D, 0xBB04), SpChange::By(4), "ldr r11, [sp], #4");
        assert_eq!(by(0xF84D, 0x0D08), SpChange::By(-8), "str r0, [sp, #-8]!");
        assert_eq!(by(0xF8DD, 0x0008), SpChange::None, "ldr.w r0, [sp, #8]");
        assert_eq!(
            by(0xE96D, 0x4502),
            SpChange::By(-8),
            "strd r4, r5, [sp, #-8]!"
        );
        assert_eq!(by(0xE8FD, 0x4502), SpChange::By(8), "ldrd r4, r5, [sp], #8");
        assert_eq!(by(0xE9CD, 0x4502), SpChange::None, "strd r4, r5, [sp, #8]");
        assert_eq!(by(0xF5AD, 0x7D00), SpChange::By(-512), "sub.w sp, sp, #512");
        assert_eq!(by(0xF50D, 0x7D00), SpChange::By(512), "add.w sp, sp, #512");
        assert_eq!(
            by(0xF2AD, 0x4D04),
            SpChange::By(-1028),
            "subw sp, sp, #1028"
        );
        assert_eq!(by(0xF20D, 0x4D04), SpChange::By(1028), "addw sp, sp, #1028");
        assert_eq!(by(0xF10D, 0x0008), SpChange::None, "add.w r0, sp, #8");
        assert_eq!(by(0xA802, 0), SpChange::None, "add r0, sp, #8");
        assert_eq!(by(0x9001, 0), SpChange::None, "str r0, [sp, #4]");
        assert_eq!(by(0x4685, 0), SpChange::Unknown, "mov sp, r0");
        assert_eq!(by(0xF380, 0x8808), SpChange::Unknown, "msr msp, r0");
        assert_eq!(by(0xEBAD, 0x0D00), SpChange::Unknown, "sub.w sp, sp, r0");
    }

    #[test]
    fn modified_immediates_expand() {
        assert_eq!(thumb_expand_imm(0x0AB), 0xAB);
        assert_eq!(thumb_expand_imm(0x1AB), 0x00AB_00AB);
        assert_eq!(thumb_expand_imm(0x2AB), 0xAB00_AB00);
        assert_eq!(thumb_expand_imm(0x3AB), 0xABAB_ABAB);
        // 1:0000000 rotated right by 0b11110 = 30: 0x200.
        assert_eq!(thumb_expand_imm(0xF00), 0x200);
    }

    #[test]
    fn a_straight_run_goes_deepest_before_it_returns() {
        // push {r4, r5, r6, r7, lr}; sub sp, #16; add sp, #16; pop {r4, r5, r6, r7, pc}
        let code = [0xF0, 0xB5, 0x84, 0xB0, 0x04, 0xB0, 0xF0, 0xBD];
        assert_eq!(deepest_below_start(&code), 36);
        // pop first: the block starts at its deepest.
        assert_eq!(deepest_below_start(&[0xF0, 0xBD]), 0);
        // push.w {r8-r11}; mov sp, r0; push {r7, lr}: the scan stops at the unknown.
        let code = [0x2D, 0xE9, 0x00, 0x0F, 0x85, 0x46, 0x80, 0xB5];
        assert_eq!(deepest_below_start(&code), 16);
    }
}
