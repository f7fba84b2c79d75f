//! Reads that must be right. Nothing on the SPI PDI is checked: a bit flipped on MISO, or
//! SPI_SEL glitching high in the middle of a read, hands the MCU data the ESC never held.
//! The ESC counts only the protocol errors it sees itself (0x030D/0x030E: a read left
//! without its termination byte, an access cut in its address phase), never a flipped bit.
//! So what decides the outputs or the state machine is read until two reads agree.
//!
//! A read equal to what was taken last time is taken at once (a corruption that happens to
//! give the old value changes nothing), so in a cycle whose outputs did not change it costs
//! nothing; a changed value costs one more read. A fault that corrupts two reads in a row
//! the same way (a bus that is broken, not disturbed) is beyond this check.

/// Reads of one confirmation, at most.
pub const MAX_READS: usize = 3;

/// How a confirmed read ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Confirmed {
    /// The data is what was taken last time.
    Same,
    /// New data, read the same twice in a row.
    New,
    /// No two reads in a row agreed within [`MAX_READS`]: the data is not to be used.
    Unstable,
}

/// Reads with `read` into `buf` until the data is confirmed (see the module). `last` is
/// what was taken before (`None`: nothing yet), `scratch` a buffer as long as `buf`.
/// On [`Confirmed::Same`] and [`Confirmed::New`], `buf` holds the data.
pub fn read_confirmed<E>(
    buf: &mut [u8],
    last: Option<&[u8]>,
    scratch: &mut [u8],
    mut read: impl FnMut(&mut [u8]) -> Result<(), E>,
) -> Result<Confirmed, E> {
    let same = |b: &[u8]| last.is_some_and(|l| same_bytes(l, b));
    read(buf)?;
    if same(buf) {
        return Ok(Confirmed::Same);
    }
    let Some(scratch) = scratch.get_mut(..buf.len()) else {
        return Ok(Confirmed::Unstable);
    };
    for _ in 1..MAX_READS {
        read(scratch)?;
        if same_bytes(scratch, buf) {
            return Ok(Confirmed::New);
        }
        buf.copy_from_slice(scratch);
        if same(buf) {
            return Ok(Confirmed::Same);
        }
    }
    Ok(Confirmed::Unstable)
}

/// Whether `a` and `b` hold the same bytes. The reads confirmed are a few bytes long: a
/// loop costs less than the call into `memcmp` that `==` on slices makes.
fn same_bytes(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x == y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::convert::Infallible;

    /// A source that gives these reads in turn (the last one from then on).
    fn reads<'a>(
        seq: &'a [[u8; 2]],
        n: &'a mut usize,
    ) -> impl FnMut(&mut [u8]) -> Result<(), Infallible> + 'a {
        move |b| {
            b.copy_from_slice(&seq[(*n).min(seq.len() - 1)]);
            *n += 1;
            Ok(())
        }
    }

    fn run(seq: &[[u8; 2]], last: Option<[u8; 2]>) -> (Confirmed, [u8; 2], usize) {
        let mut n = 0;
        let mut buf = [0u8; 2];
        let mut scratch = [0u8; 2];
        let r = read_confirmed(
            &mut buf,
            last.as_ref().map(|l| &l[..]),
            &mut scratch,
            reads(seq, &mut n),
        );
        let Ok(r) = r;
        (r, buf, n)
    }

    #[test]
    fn unchanged_data_costs_one_read() {
        assert_eq!(run(&[[1, 2]], Some([1, 2])), (Confirmed::Same, [1, 2], 1));
    }

    #[test]
    fn new_data_is_read_twice() {
        assert_eq!(
            run(&[[3, 4], [3, 4]], Some([1, 2])),
            (Confirmed::New, [3, 4], 2)
        );
        assert_eq!(run(&[[3, 4], [3, 4]], None), (Confirmed::New, [3, 4], 2));
    }

    #[test]
    fn a_corrupted_read_is_never_taken() {
        // A flipped bit in the first read: the second and third agree.
        assert_eq!(
            run(&[[3, 0x84], [3, 4], [3, 4]], Some([1, 2])),
            (Confirmed::New, [3, 4], 3)
        );
        // A corrupted second read: two reads in a row decide, here the third agrees with
        // the second (a fault that lasts two reads is beyond this check).
        assert_eq!(
            run(&[[3, 4], [0xFF, 0xFF], [3, 4]], Some([1, 2])).0,
            Confirmed::Unstable
        );
        assert_eq!(
            run(&[[0xFF, 0xFF], [3, 4], [3, 4]], Some([1, 2])),
            (Confirmed::New, [3, 4], 3)
        );
        // The old value comes back: nothing changed after all.
        assert_eq!(
            run(&[[0xFF, 0xFF], [1, 2]], Some([1, 2])),
            (Confirmed::Same, [1, 2], 2)
        );
        // Three different reads: nothing is taken.
        assert_eq!(
            run(&[[5, 5], [6, 6], [7, 7]], Some([1, 2])).0,
            Confirmed::Unstable
        );
    }

    #[test]
    fn bus_errors_pass_through() {
        let mut buf = [0u8; 2];
        let mut scratch = [0u8; 2];
        let r = read_confirmed(&mut buf, None, &mut scratch, |_| Err("bus"));
        assert_eq!(r, Err("bus"));
    }
}
