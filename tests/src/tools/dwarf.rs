//! The DWARF of an ELF as an address-to-function context (`addr2line`, inlined frames
//! included), for the benches that name where the cycles of a program go: `cargo xtask bench
//! --by-function` (the Cortex-M3 bench) and the co-simulator's profile of the release image.

use std::rc::Rc;

/// The section reader of the context: sections copied out of the ELF once.
pub type Reader = gimli::EndianRcSlice<gimli::RunTimeEndian>;

/// The context of `file`'s DWARF sections (a section the file lacks reads as empty).
pub fn context(file: &object::File) -> Result<addr2line::Context<Reader>, gimli::Error> {
    use object::{Object, ObjectSection};
    let endian = if file.is_little_endian() {
        gimli::RunTimeEndian::Little
    } else {
        gimli::RunTimeEndian::Big
    };
    let load = |id: gimli::SectionId| -> Result<Reader, gimli::Error> {
        let data = file
            .section_by_name(id.name())
            .and_then(|s| s.uncompressed_data().ok())
            .map(|d| Rc::<[u8]>::from(d.as_ref()))
            .unwrap_or_else(|| Rc::from(&[][..]));
        Ok(gimli::EndianRcSlice::new(data, endian))
    };
    addr2line::Context::from_dwarf(gimli::Dwarf::load(load)?)
}
