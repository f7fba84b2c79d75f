//! The image's code as the profiler sees it: for every instruction address, the function it
//! belongs to and the functions the compiler inlined there (the ELF's DWARF line and inline
//! information, `debug = 2` in the release profile), so cycles can be counted for code that
//! has no symbol of its own (the sample drain inlined into the PDI task's handler, say).
//!
//! A *chain* is the list of functions at one address, outermost (the symbol) first,
//! innermost (the source of the instruction) last; chains are interned and numbered.

use crate::image::Image;
use crate::thumb;
use std::collections::HashMap;
use std::rc::Rc;
use virtual_board::tools::dwarf::Reader;

/// Function names and inline chains of an image, filled as addresses are asked for.
pub struct CodeMap {
    dwarf: Option<addr2line::Context<Reader>>,
    names: Vec<String>,
    name_ids: HashMap<String, u32>,
    chains: Vec<Vec<u32>>,
    chain_ids: HashMap<Vec<u32>, u32>,
}

/// The chain of addresses outside any known function.
pub const UNKNOWN_CHAIN: u32 = 0;

impl CodeMap {
    /// The map of `image` (without DWARF, chains are the symbols alone).
    pub fn new(image: &Image) -> Self {
        let mut map = Self {
            dwarf: load_dwarf(&image.elf),
            names: Vec::new(),
            name_ids: HashMap::new(),
            chains: Vec::new(),
            chain_ids: HashMap::new(),
        };
        let unknown = map.name_id("(no symbol)");
        map.chain_id(vec![unknown]);
        map
    }

    fn name_id(&mut self, name: &str) -> u32 {
        if let Some(&id) = self.name_ids.get(name) {
            return id;
        }
        let id = self.names.len() as u32;
        self.names.push(name.to_string());
        self.name_ids.insert(name.to_string(), id);
        id
    }

    fn chain_id(&mut self, chain: Vec<u32>) -> u32 {
        if let Some(&id) = self.chain_ids.get(&chain) {
            return id;
        }
        let id = self.chains.len() as u32;
        self.chains.push(chain.clone());
        self.chain_ids.insert(chain, id);
        id
    }

    /// The chain at instruction address `addr` (Thumb bit ignored).
    pub fn chain_at(&mut self, image: &Image, addr: u32) -> u32 {
        let addr = addr & !1;
        let Some((symbol, _)) = image.symbolize(addr) else {
            return UNKNOWN_CHAIN;
        };
        let symbol = strip_hash(symbol).to_string();
        let mut names = vec![symbol];
        if let Some(ctx) = &self.dwarf {
            // Frames come innermost first; the outermost is the symbol itself.
            if let Ok(mut frames) = ctx.find_frames(u64::from(addr)).skip_all_loads() {
                let mut inlined = Vec::new();
                while let Ok(Some(frame)) = frames.next() {
                    if let Some(f) = frame.function {
                        if let Ok(name) = f.demangle() {
                            inlined.push(strip_hash(&name).to_string());
                        }
                    }
                }
                // Drop the outermost frame (the symbol's own function), keep the inlined ones.
                inlined.pop();
                names.extend(inlined.into_iter().rev());
            }
        }
        let ids = names.iter().map(|n| self.name_id(n)).collect();
        self.chain_id(ids)
    }

    /// The function names of chain `id`, outermost first.
    pub fn chain(&self, id: u32) -> Vec<&str> {
        self.chains
            .get(id as usize)
            .map(|c| c.iter().map(|&n| self.names[n as usize].as_str()).collect())
            .unwrap_or_default()
    }

    /// Number of chains so far.
    pub fn chains(&self) -> usize {
        self.chains.len()
    }
}

/// One translated block of code as the engine runs it: its instructions, and how many of
/// them belong to each chain.
#[derive(Clone, Debug, Default)]
pub struct Block {
    size: u32,
    /// Instructions in the block.
    pub instructions: u64,
    /// (chain, instructions), in the order of the code.
    pub runs: Vec<(u32, u32)>,
    /// How far SP goes below its value at the block's start while the block runs (bytes).
    pub sp_dip: u32,
}

/// The blocks of an image, decoded once each: flash blocks in a table by address, others
/// (code in RAM) by address and size.
pub struct Blocks {
    image: Rc<Image>,
    /// The chains of the image.
    pub code: CodeMap,
    flash: Vec<Option<Block>>,
    other: HashMap<(u32, u32), Block>,
}

impl Blocks {
    /// The table of `image`.
    pub fn new(image: Rc<Image>) -> Self {
        let code = CodeMap::new(&image);
        Self {
            flash: vec![None; image.flash.len() / 2],
            image,
            code,
            other: HashMap::new(),
        }
    }

    /// The block of `size` bytes at `addr`; `bytes` reads its code when it is not in flash.
    pub fn get(&mut self, addr: u32, size: u32, bytes: impl FnOnce() -> Vec<u8>) -> &Block {
        // Offset in the chip's flash (code runs from its flash base, the STM32's also from the
        // alias at 0: both are the same blocks).
        let off = addr.wrapping_sub(self.image.chip.flash().start);
        let off = if off as usize >= self.image.flash.len() {
            addr
        } else {
            off
        };
        let slot = (off / 2) as usize;
        let in_flash = (off as usize + size as usize) <= self.image.flash.len();
        if in_flash {
            if self.flash[slot].as_ref().is_none_or(|b| b.size != size) {
                let code = self.image.flash[off as usize..(off + size) as usize].to_vec();
                let block = self.decode(addr, size, &code);
                self.flash[slot] = Some(block);
            }
            return self.flash[slot].as_ref().expect("just filled");
        }
        if !self.other.contains_key(&(addr, size)) {
            let block = self.decode(addr, size, &bytes());
            self.other.insert((addr, size), block);
        }
        &self.other[&(addr, size)]
    }

    fn decode(&mut self, addr: u32, size: u32, code: &[u8]) -> Block {
        let mut block = Block {
            size,
            sp_dip: thumb::deepest_below_start(code),
            ..Default::default()
        };
        let mut i = 0;
        while i + 1 < code.len() {
            let chain = self.code.chain_at(&self.image, addr + i as u32);
            match block.runs.last_mut() {
                Some((c, n)) if *c == chain => *n += 1,
                _ => block.runs.push((chain, 1)),
            }
            block.instructions += 1;
            i += thumb::length(u16::from_le_bytes([code[i], code[i + 1]]));
        }
        block
    }
}

/// `path::name::h0123456789abcdef` without the hash.
fn strip_hash(name: &str) -> &str {
    match name.rfind("::h") {
        Some(i) if name.len() - i == 19 => &name[..i],
        _ => name,
    }
}

fn load_dwarf(elf: &[u8]) -> Option<addr2line::Context<Reader>> {
    virtual_board::tools::dwarf::context(&object::File::parse(elf).ok()?).ok()
}

#[cfg(test)]
mod tests {
    use super::strip_hash;

    #[test]
    fn hashes_are_stripped() {
        assert_eq!(
            strip_hash("firmware::stacks::ethercat::SlaveApp::poll::h0123456789abcdef"),
            "firmware::stacks::ethercat::SlaveApp::poll"
        );
        assert_eq!(strip_hash("EINT3"), "EINT3");
    }
}
