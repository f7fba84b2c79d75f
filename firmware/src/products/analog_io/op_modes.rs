//! The DC op modes that choose oversampling (docs/book/oversampling.md, "For masters"): one
//! per bus cycle at which the module streams every conversion, each with the PDO
//! assignment it writes (ESI `Dc/OpMode/Sm/Pdo@OSFac`, one SII DC entry each), so TwinCAT
//! users pick oversampling on the DC tab as for Beckhoff's EL3702/EL4732.
//!
//! SYNC0 is the bus cycle, as in the plain "DC" mode (`crate::stacks::ethercat::op_modes::dc_sync0`:
//! AssignActivate 0x0300, `CycleTimeSync0 Factor="1"`), and there is no SYNC1: the module
//! clocks its converters itself, locked to the SYNC0 edges; the factor is the assignment,
//! not a SYNC0 divider. Per cycle the inputs take the block status, the block time and the
//! fewest sample PDOs that hold the cycle's largest block (so every conversion reaches the
//! master), the outputs the most update PDOs the firmware admits beside them
//! (`io::analog::oversampling::admit`, `io::analog::output_blocks::admit`, the minimum
//! cycle); the host tests (`tests/op_modes.rs`) run that admission on every mode.
//! Description only: the image never links these.

use super::od::RX_ASSIGN_DEFAULT;
use crate::io::analog::output_blocks::UPDATE_PDO;
use crate::io::analog::oversampling::{SAMPLE_PDO, STATUS_PDO, TIME_PDO};
use crate::stacks::ethercat::op_modes::dc_sync0;
use coe_core::device::oversampling::{OpModePdo, OpModeSm, OpModeWithPdos};

/// An oversampling op mode and the bus cycle it is made for (the ESI cannot say it: the
/// name and description do).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleOpMode {
    /// The bus cycle = SYNC0 cycle (ns).
    pub cycle_ns: u32,
    /// The op mode with its assignment.
    pub mode: OpModeWithPdos,
}

/// SM3: block status, block time and `sample_pdos` sample PDOs (32 samples each).
const fn inputs(sample_pdos: u8) -> [OpModePdo; 3] {
    [
        OpModePdo::plain(STATUS_PDO),
        OpModePdo::plain(TIME_PDO),
        OpModePdo::replicated(SAMPLE_PDO, sample_pdos),
    ]
}

static INPUTS_1MS: [OpModePdo; 3] = inputs(8);
static INPUTS_500US: [OpModePdo; 3] = inputs(4);
static INPUTS_270US: [OpModePdo; 3] = inputs(3);
/// SM2 at 1 ms: 5 update PDOs, 25 updates (40 us apart).
static OUTPUTS_1MS: [OpModePdo; 1] = [OpModePdo::replicated(UPDATE_PDO, 5)];
/// SM2 at 500 us: 2 update PDOs, 10 updates (50 us apart).
static OUTPUTS_500US: [OpModePdo; 1] = [OpModePdo::replicated(UPDATE_PDO, 2)];
/// SM2 at 270 us: no update PDO fits beside the stream; the one-value outputs (0x1600).
static OUTPUTS_270US: [OpModePdo; 1] = [OpModePdo::plain(RX_ASSIGN_DEFAULT[0])];

/// The oversampling op modes, longest cycle first. 250 us and shorter are below the
/// module's minimum cycle (270 us); above 1 024 us the 8 sample PDOs cannot hold a block.
/// Names and descriptions are short: the SII (2 KB EEPROM) carries them too. "DC-OS" is
/// DC oversampling; the rates are the whole module's: AI all eight channels' conversions
/// (250 kSPS), AO updates per second on both outputs at once.
pub const CYCLE_OP_MODES: [CycleOpMode; 3] = [
    CycleOpMode {
        cycle_ns: 1_000_000,
        mode: OpModeWithPdos {
            mode: dc_sync0("DcOs1ms", "DC-OS 1 ms: AI 250 kSPS, AO 25 kHz"),
            sms: &[
                OpModeSm {
                    sm: 2,
                    pdos: &OUTPUTS_1MS,
                },
                OpModeSm {
                    sm: 3,
                    pdos: &INPUTS_1MS,
                },
            ],
        },
    },
    CycleOpMode {
        cycle_ns: 500_000,
        mode: OpModeWithPdos {
            mode: dc_sync0("DcOs500us", "DC-OS 500 us: AI 250 kSPS, AO 20 kHz"),
            sms: &[
                OpModeSm {
                    sm: 2,
                    pdos: &OUTPUTS_500US,
                },
                OpModeSm {
                    sm: 3,
                    pdos: &INPUTS_500US,
                },
            ],
        },
    },
    CycleOpMode {
        cycle_ns: 270_000,
        mode: OpModeWithPdos {
            mode: dc_sync0("DcOs270us", "DC-OS 270 us: AI 250 kSPS, AO 3.7 kHz"),
            sms: &[
                OpModeSm {
                    sm: 2,
                    pdos: &OUTPUTS_270US,
                },
                OpModeSm {
                    sm: 3,
                    pdos: &INPUTS_270US,
                },
            ],
        },
    },
];

/// The op modes of [`CYCLE_OP_MODES`] as the description lists them (after the plain ones).
pub static OP_MODES: [OpModeWithPdos; CYCLE_OP_MODES.len()] = {
    let mut out = [CYCLE_OP_MODES[0].mode; CYCLE_OP_MODES.len()];
    let mut i = 0;
    while i < out.len() {
        out[i] = CYCLE_OP_MODES[i].mode;
        i += 1;
    }
    out
};
