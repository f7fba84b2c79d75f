//! Output oversampling through the product's application: the block counter (0x7010:01,
//! PDO 0x1610) lets the module refuse a block the master sent twice, and the block status
//! (0x1A10, without the sample stream) tells the master.

use super::op_modes::assign;
use super::Rig;
use crate::io::analog::output_blocks::{COUNTER_PDO, UPDATES_PER_PDO, UPDATE_PDO};
use crate::io::analog::oversampling::{STATUS_OUTPUTS_HELD, STATUS_OUTPUTS_REFUSED, STATUS_PDO};
use crate::products::analog_io::{application, CONFIG};
use std::vec::Vec;

/// The output image of 0x1610 + 0x1620: the counter, then 5 updates of (AO1, AO2).
fn image(counter: u16, code: u16) -> Vec<u8> {
    let mut out = counter.to_le_bytes().to_vec();
    for k in 0..UPDATES_PER_PDO as u16 {
        out.extend_from_slice(&(code + k).to_le_bytes());
        out.extend_from_slice(&(!(code + k)).to_le_bytes());
    }
    out
}

/// OP in DC SYNC0 at 1 ms with 0x1610 and 0x1620 in 0x1C12, and the block status 0x1A10
/// after the plain inputs in 0x1C13; the ADC's grid known (no conversion yet).
fn op_with_the_counter() -> Rig {
    let mut r = Rig::with_app(CONFIG, application());
    let [m0, m1, sm2, sm3] = CONFIG.sm;
    r.esc.master_sm(0, m0.start, m0.len, m0.control, true);
    r.esc.master_sm(1, m1.start, m1.len, m1.control, true);
    assert_eq!(r.request(0x02), (0x02, 0));
    assign(&mut r, 0x1C12, &[COUNTER_PDO, UPDATE_PDO]).unwrap();
    let plain = r.upload(0x1C13, 1).expect("0x1C13:01");
    let plain = u16::from_le_bytes([plain[0], plain[1]]);
    assign(&mut r, 0x1C13, &[plain, STATUS_PDO]).unwrap();
    r.app.application_mut().stream.set_word0(0);
    let in_len = r.app.application().pd.input_len() as u16;
    r.esc
        .master_sm(2, sm2.start, image(0, 0).len() as u16, sm2.control, true);
    r.esc.master_sm(3, sm3.start, in_len, sm3.control, true);
    r.esc.master_dc(0x03, 1_000_000);
    assert_eq!(r.request(0x04), (0x04, 0));
    assert_eq!(r.request(0x08), (0x08, 0));
    r
}

/// One cycle: the master's frame with `image`, then the SYNC0 edge and the poll after it.
/// Returns whether the block was published for that edge, and the input block's status
/// the master reads then (the last byte of 0x1A10, at the end of the image) without b2:
/// the update interrupt that counts the holds does not run in this rig.
fn cycle(r: &mut Rig, image: &[u8]) -> (bool, u8) {
    r.esc.master_write_outputs(image);
    r.irq();
    let next = r.stage.sync0_counts().edges.wrapping_add(1);
    let published = r.stage.blocks.has_block_for(next);
    r.sync0();
    let inputs = r.esc.master_read_inputs();
    assert_eq!(inputs.len(), r.app.application().pd.input_len());
    (published, inputs[inputs.len() - 1] & !STATUS_OUTPUTS_HELD)
}

const REFUSED: (bool, u8) = (false, STATUS_OUTPUTS_REFUSED);
const PLAYED: (bool, u8) = (true, 0);

#[test]
fn a_block_whose_counter_repeats_is_refused_and_the_next_input_block_says_so() {
    let mut r = op_with_the_counter();
    // The third frame repeats the second's counter (with new codes: it is still refused).
    let got: Vec<(bool, u8)> = [(1, 100), (2, 200), (2, 300), (3, 400), (4, 500)]
        .into_iter()
        .map(|(counter, code)| cycle(&mut r, &image(counter, code)))
        .collect();
    assert_eq!(got, [PLAYED, PLAYED, REFUSED, PLAYED, PLAYED]);
}

#[test]
fn a_second_frame_before_the_same_edge_is_no_refusal() {
    let mut r = op_with_the_counter();
    assert_eq!(cycle(&mut r, &image(1, 100)), PLAYED);
    // Two frames in one cycle, the same block: the first plays, the second is dropped
    // without a word; the next cycle's block plays.
    r.esc.master_write_outputs(&image(2, 200));
    r.irq();
    assert_eq!(cycle(&mut r, &image(2, 200)), PLAYED);
    assert_eq!(cycle(&mut r, &image(3, 300)), PLAYED);
}

#[test]
fn a_new_stream_accepts_any_first_counter() {
    let mut r = op_with_the_counter();
    assert_eq!(cycle(&mut r, &image(7, 100)), PLAYED);
}

#[test]
fn a_block_no_two_reads_agree_on_is_refused_and_the_next_input_block_says_so() {
    let mut r = op_with_the_counter();
    let sm2 = CONFIG.sm[2].start;
    let mut got = Vec::new();
    for (counter, code) in (1u16..).zip([100, 200, 300, 400]) {
        if counter == 3 {
            // All three reads of the block corrupted, each differently.
            r.esc.corrupt_next_read = Some((sm2, 4, 0x01, 3));
        }
        got.push(cycle(&mut r, &image(counter, code)));
    }
    assert_eq!(r.esc.corrupt_next_read, None, "three reads hit");
    assert_eq!(got, [PLAYED, PLAYED, REFUSED, PLAYED]);
}
