//! Fuzz target: the SII reader (`coe_core::sii::reader`) on arbitrary images never panics,
//! every category it yields lies inside the image, the category walk ends, and every view of
//! every category body reads to its end.
#![no_main]

use coe_core::sii::reader::{DcOpModes, General, Pdos, Sii, Strings, SyncManagers};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|image: &[u8]| {
    let sii = Sii::new_unchecked(image);
    let _ = (
        sii.checksum_valid(),
        sii.identity(),
        sii.bootstrap_mailbox(),
        sii.standard_mailbox(),
        sii.mailbox_protocols(),
        sii.eeprom_kbit(),
        sii.version(),
    );
    let mut count = 0usize;
    for category in sii.categories() {
        count += 1;
        assert!(count <= image.len() / 4 + 1, "the walk advances");
        let Ok(c) = category else { break };
        assert!(c.at + 4 + c.data.len() <= image.len());
        let strings = Strings::new(c.data);
        for s in strings.iter() {
            assert!(s.len() < c.data.len());
        }
        let _ = strings.get(u8::try_from(c.kind & 0xFF).unwrap_or(0));
        let g = General::new(c.data);
        let _ = (
            g.name_index(),
            g.coe_details(),
            g.ebus_current_ma(),
            g.physical_ports(),
        );
        assert!(SyncManagers::new(c.data).count() <= c.data.len() / 8);
        for pdo in Pdos::new(c.data).flatten() {
            assert!(pdo.entries().count() == pdo.entry_count());
        }
        assert!(DcOpModes::new(c.data).count() <= c.data.len() / 24);
    }
    let _ = sii.strings().iter().count();
});
