//! SYSTEM TEST: the conformance checks of `lpc1754_cosim::peer::conformance` against this
//! project's release image and against SOES (tests/soes) on the co-simulated board; prints
//! the table (`cargo test -p lpc1754-cosim --test peer_conformance -- --nocapture`). This
//! project's image must pass every check; SOES's verdicts are the comparison, not asserted,
//! but its runs must not fault the co-simulated core.

use lpc1754_cosim::peer;
use lpc1754_cosim::run::load_image;
use virtual_board::tools::peer_figures::conformance_table;

#[test]
fn conformance_of_both_stacks() {
    let ours = load_image().unwrap();
    let soes = peer::soes::load().unwrap();
    let rows = peer::conformance_rows(&ours, &soes).unwrap();
    println!("{}", conformance_table(&rows, "SOES"));
    for r in &rows {
        assert!(
            r.ours.pass,
            "this project fails: {} ({})",
            r.check, r.ours.detail
        );
        assert!(
            !r.peer.detail.contains("faulted"),
            "SOES faulted in: {} ({})",
            r.check,
            r.peer.detail
        );
    }
}
