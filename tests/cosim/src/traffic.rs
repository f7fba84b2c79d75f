//! The traffic a real master makes while it runs process data (issue 33), for the DC runs
//! of [`crate::bench`]: mailbox traffic in OP, a master whose frames jitter, inputs that
//! move. A cycle time is judged under it (docs/book/traffic.md).
//!
//! - **Mailbox in OP**: SDO exchanges back to back for the whole run ([`sdo_traffic`]): a
//!   segmented upload of the largest object (the module description), the SDO Information
//!   OD list (in fragments), a complete-access upload of 0x1C32 and an expedited upload.
//! - **A jittering master**: each cyclic frame leaves at its nominal time (half a cycle
//!   before SYNC0) plus a uniform offset in `[-jitter, +jitter]` ([`Jitter`], a fixed seed:
//!   every run sees the same offsets).
//! - **Moving inputs**: a sine on every ADC channel, each at its own frequency and phase
//!   ([`moving_inputs`]): an input image equal to the previous cycle's on every channel is
//!   an SM3 update that came late.

use firmware::products::analog_io::device::DEVICE;
use firmware::products::analog_io::od::MODULE_DESCRIPTION_INDEX;
use std::cell::Cell;
use virtual_board::models::adc::Signal;
use virtual_board::rig::sdo_client::{
    coe_service, payload, RegisterPort, SdoClient, MAILBOX_TYPE_COE,
};

/// The master's frame jitter chosen for the judgement: uniform +-10 us around the nominal
/// send time. It models a master on a real-time kernel with a dedicated NIC (the send
/// path's wake-up and the NIC's queue), as TwinCAT or SOEM on PREEMPT_RT; the project's
/// own Python master on a loaded virtual machine is far worse (docs/book/frame-serving.md)
/// and is not what a cycle time is promised for.
pub const MASTER_JITTER_NS: u64 = 10_000;

/// What a DC run adds to the ideal master.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Traffic {
    /// SDO traffic in OP, back to back ([`sdo_traffic`]).
    pub mailbox_in_op: bool,
    /// Frame jitter, +- this much (ns), uniform.
    pub jitter_ns: u64,
    /// A moving signal on every ADC channel ([`moving_inputs`]); else the constants of
    /// [`crate::bench::INPUTS_V`].
    pub moving_inputs: bool,
}

impl Traffic {
    /// The ideal master: frames exactly half a cycle before SYNC0, no mailbox in OP,
    /// constant inputs.
    pub const IDEAL: Self = Self {
        mailbox_in_op: false,
        jitter_ns: 0,
        moving_inputs: false,
    };

    /// The traffic a cycle time is judged under.
    pub const REAL_MASTER: Self = Self {
        mailbox_in_op: true,
        jitter_ns: MASTER_JITTER_NS,
        moving_inputs: true,
    };

    /// One line for reports.
    pub fn describe(&self) -> String {
        if *self == Self::IDEAL {
            return "ideal master (no mailbox in OP, no jitter, constant inputs)".into();
        }
        format!(
            "{}frame jitter +-{} us uniform, {} inputs",
            if self.mailbox_in_op {
                "SDO traffic in OP back to back (segmented upload, SDO Information, complete \
                 access), "
            } else {
                ""
            },
            self.jitter_ns / 1000,
            if self.moving_inputs {
                "moving"
            } else {
                "constant"
            }
        )
    }
}

/// Uniform offsets in `[-span, +span]` ns from a fixed seed (xorshift64*).
#[derive(Debug, Clone)]
pub struct Jitter {
    state: u64,
    span: u64,
}

impl Jitter {
    /// Offsets within +-`span_ns`.
    pub fn new(span_ns: u64) -> Self {
        Self {
            state: 0x9E37_79B9_7F4A_7C15,
            span: span_ns,
        }
    }

    /// The next offset (ns).
    pub fn next_ns(&mut self) -> i64 {
        if self.span == 0 {
            return 0;
        }
        self.state ^= self.state >> 12;
        self.state ^= self.state << 25;
        self.state ^= self.state >> 27;
        let r = self.state.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (r % (2 * self.span + 1)) as i64 - self.span as i64
    }
}

/// A sine on every channel, 1 to 9 V, from 1.1 kHz up in 0.37 kHz steps, each with its own
/// phase: between two cycles of up to 1 ms every channel moves by far more than an LSB
/// most of the time, and never all of them stay within one LSB together.
pub fn moving_inputs() -> [Signal; 8] {
    std::array::from_fn(|ch| Signal::Sine {
        amplitude: 4.0,
        offset: 5.0,
        freq_hz: 1_100.0 + 370.0 * ch as f64,
        phase: 0.7 * ch as f64,
    })
}

/// What the SDO traffic did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SdoCounts {
    /// Exchanges completed (uploads, SDO Information requests).
    pub exchanges: u64,
    /// Upload segments among them.
    pub segments: u64,
    /// SDO Information fragments read.
    pub fragments: u64,
}

/// SDO traffic back to back on `port` until `stop` is set: the module description
/// (segmented), the OD list (SDO Information, in fragments), 0x1C32 by complete access,
/// 0x1018:01 expedited, again and again; each checked (an abort or a wrong length is an
/// error). The counts go to `counts` as they come.
pub async fn sdo_traffic<P: RegisterPort>(
    port: &P,
    stop: &Cell<bool>,
    counts: &Cell<SdoCounts>,
) -> Result<(), String> {
    let (mbx_out, mbx_in) = (DEVICE.sync_managers[0], DEVICE.sync_managers[1]);
    let mut client = SdoClient::<128>::new(mbx_out.start, mbx_in.start, 1);
    let mut description_len = None;
    while !stop.get() {
        let mut c = counts.get();
        let up = client
            .upload(port, MODULE_DESCRIPTION_INDEX, 0)
            .await
            .map_err(|e| format!("module description: {e}"))?;
        if up.segments == 0 || *description_len.get_or_insert(up.data.len()) != up.data.len() {
            return Err("the module description came without segments or changed".into());
        }
        c.segments += up.segments as u64;
        c.fragments += od_list(&mut client, port).await?;
        let sync = client
            .upload_with(port, 0x1C32, 0, true, &mut |_| {})
            .await
            .map_err(|e| format!("0x1C32 complete access: {e}"))?;
        if sync.data.len() < 4 {
            return Err(format!("0x1C32 complete access: {} bytes", sync.data.len()));
        }
        client
            .upload(port, 0x1018, 1)
            .await
            .map_err(|e| format!("0x1018:01: {e}"))?;
        c.exchanges += 4;
        counts.set(c);
    }
    Ok(())
}

/// SDO Information "get OD list" (all objects): the request, then every fragment until the
/// last; returns the fragments read.
async fn od_list<P: RegisterPort>(client: &mut SdoClient<128>, port: &P) -> Result<u64, String> {
    // CoE header (SDO Information), opcode 1 (get OD list request), reserved, fragments
    // left 0, list type 1 (all objects).
    let request = [0x00, 0x80, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00];
    let mailbox = client.mailbox();
    if !mailbox.send(port, MAILBOX_TYPE_COE, &request).await? {
        return Err("SDO Information: the write mailbox is full".into());
    }
    let mut fragments = 0;
    for _ in 0..64 {
        let frame = mailbox.read(port).await?;
        let p = payload(&frame)?;
        let service = p.get(..2).map(|h| u16::from_le_bytes([h[0], h[1]]) >> 12);
        if service == Some(coe_service::EMERGENCY) {
            continue;
        }
        let opcode = *p.get(2).ok_or("SDO Information: short frame")?;
        if opcode & 0x7F != 0x02 {
            return Err(format!(
                "SDO Information: opcode {opcode:#04x} instead of the OD list response"
            ));
        }
        fragments += 1;
        if opcode & 0x80 == 0 {
            return Ok(fragments);
        }
    }
    Err("SDO Information: more than 64 fragments".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jitter_is_uniform_within_its_span_and_repeatable() {
        let mut j = Jitter::new(10_000);
        let v: Vec<i64> = (0..20_000).map(|_| j.next_ns()).collect();
        assert!(v.iter().all(|x| x.abs() <= 10_000));
        let (lo, hi) = (
            v.iter().filter(|x| **x < -5_000).count(),
            v.iter().filter(|x| **x > 5_000).count(),
        );
        // A quarter of the values in each outer quarter of the span, give or take.
        for n in [lo, hi] {
            assert!((4_500..5_500).contains(&n), "{n}");
        }
        assert_eq!(Jitter::new(10_000).next_ns(), v[0]);
        assert_eq!(Jitter::new(0).next_ns(), 0);
    }

    #[test]
    fn the_inputs_move_on_every_channel_between_cycles() {
        let s = moving_inputs();
        let lsb = 10.0 / 32768.0;
        // Never all eight channels within one LSB of their value a cycle earlier.
        for cycle_ns in [50_000u64, 100_000, 1_000_000] {
            for k in 1..2_000u64 {
                let (t0, t1) = ((k - 1) * cycle_ns, k * cycle_ns);
                assert!(
                    s.iter()
                        .any(|x| (x.eval(t1) - x.eval(t0)).abs() > 2.0 * lsb),
                    "cycle {cycle_ns} ns, k {k}"
                );
            }
        }
    }
}
