//! `cargo xtask size`: the build's flash/RAM figures and where they go, per crate and per
//! symbol, from the ELF symbol table (demangled paths grouped by their first segment).
//! With `--by-function`, the code's bytes also per owning function with the DWARF's inlined
//! frames: with LTO most code is inlined into a few task bodies, whose symbols alone do not
//! say what in them is big.

use crate::bench::by_function::{self, Dwarf, Symbols};
use crate::build::{self, print_usage};
use crate::image::{self, Place, SectionInfo};
use crate::util::Result;
use object::{Object, ObjectSection, ObjectSymbol, SectionKind, SymbolKind};
use std::collections::BTreeMap;

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// How many of the largest symbols to list.
    #[arg(long, default_value_t = 25)]
    pub top: usize,
    /// Accept a protecting CRP word (see `build --allow-crp`).
    #[arg(long)]
    pub allow_crp: bool,
    /// The product whose image to look at (default: the default product).
    #[arg(long, value_name = "NAME")]
    pub product: Option<String>,
    /// Also the code's bytes per owning function and per crate, inlined code counted to the
    /// innermost workspace function it was inlined from (as `bench --by-function` counts
    /// instructions).
    #[arg(long)]
    pub by_function: bool,
}

/// One symbol with its crate and memory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Symbol {
    /// Demangled name without hash.
    pub name: String,
    /// Crate (first path segment), or `[C/asm]` for unmangled symbols.
    pub krate: String,
    /// Size in bytes.
    pub size: u64,
    /// Memory it occupies.
    pub place: Place,
}

/// The crate a demangled symbol path belongs to: the first path segment; for
/// `<Type as Trait>::f` the type's crate, or the trait's when the type is a primitive or a
/// generic parameter (`<&str as core::fmt::Display>::fmt` -> `core`). Unmangled symbols
/// (interrupt handlers, `main`, compiler-builtins' C names) are `[unmangled]`.
pub fn crate_of(demangled: &str, mangled: bool) -> String {
    if !mangled {
        return "[unmangled]".into();
    }
    fn first_segment(s: &str) -> &str {
        let s = s.trim_start_matches(['<', '&', '*', '[', '(', ' ']);
        let s = s
            .strip_prefix("mut ")
            .or_else(|| s.strip_prefix("const "))
            .or_else(|| s.strip_prefix("dyn "))
            .unwrap_or(s)
            .trim_start_matches(['<', '&', '[', '(']);
        let end = s
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(s.len());
        &s[..end]
    }
    const PRIMITIVES: [&str; 17] = [
        "str", "u8", "u16", "u32", "u64", "u128", "usize", "i8", "i16", "i32", "i64", "i128",
        "isize", "bool", "char", "f32", "f64",
    ];
    let first = first_segment(demangled);
    let is_path = demangled
        .trim_start_matches(['<', '&', '*', '[', '(', ' '])
        .trim_start_matches("mut ")
        .trim_start_matches("dyn ")
        .get(first.len()..)
        .is_some_and(|rest| rest.starts_with("::"));
    if demangled.starts_with('<') && (PRIMITIVES.contains(&first) || !is_path) {
        if let Some((_, tr)) = demangled.split_once(" as ") {
            let t = first_segment(tr);
            if !t.is_empty() {
                return t.to_string();
            }
        }
    }
    if first.is_empty() {
        "[other]".into()
    } else {
        first.to_string()
    }
}

/// The symbols with a size, classified by the section they are in.
pub fn symbols(data: &[u8], sections: &[SectionInfo]) -> Result<Vec<Symbol>> {
    let file = object::File::parse(data).map_err(|e| format!("cannot read the ELF: {e}"))?;
    let mut out = Vec::new();
    for sym in file.symbols() {
        if sym.size() == 0 || !matches!(sym.kind(), SymbolKind::Text | SymbolKind::Data) {
            continue;
        }
        let Some(index) = sym.section_index() else {
            continue;
        };
        let Ok(section) = file.section_by_index(index) else {
            continue;
        };
        let sname = section.name().unwrap_or("");
        let place = sections
            .iter()
            .find(|s| s.name == sname)
            .map(|s| s.place)
            .unwrap_or(Place::None);
        if place == Place::None {
            continue;
        }
        let raw = sym.name().unwrap_or("?");
        let (name, mangled) = match rustc_demangle::try_demangle(raw) {
            Ok(d) => (format!("{d:#}"), true),
            Err(_) => (raw.to_string(), false),
        };
        out.push(Symbol {
            krate: crate_of(&name, mangled),
            name,
            size: sym.size(),
            place,
        });
    }
    Ok(out)
}

/// Flash and RAM bytes per crate, largest flash first.
pub fn by_crate(symbols: &[Symbol]) -> Vec<(String, u64, u64)> {
    let mut m: BTreeMap<&str, (u64, u64)> = BTreeMap::new();
    for s in symbols {
        let e = m.entry(&s.krate).or_default();
        match s.place {
            Place::Flash => e.0 += s.size,
            Place::FlashAndRam => {
                e.0 += s.size;
                e.1 += s.size;
            }
            Place::Ram | Place::AhbSram => e.1 += s.size,
            Place::None => {}
        }
    }
    let mut v: Vec<_> = m
        .into_iter()
        .map(|(k, (f, r))| (k.to_string(), f, r))
        .collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(b.2.cmp(&a.2)).then(a.0.cmp(&b.0)));
    v
}

pub fn run(args: &Args) -> Result {
    let out = build::build_unchecked(&build::Args {
        allow_crp: args.allow_crp,
        product: args.product.clone(),
    })?;
    println!("product: {} ({})", out.product.name, out.product.summary);
    let data = std::fs::read(&out.elf).map_err(|e| format!("cannot read the ELF: {e}"))?;
    let map = crate::mcu::of(out.product.board.mcu()).map;
    let sections = image::sections_in(&data, &map).map_err(|e| e.to_string())?;
    println!("sections:");
    for s in sections.iter().filter(|s| s.place != Place::None) {
        let lma = s
            .load_addr
            .filter(|l| *l != s.addr)
            .map(|l| format!(" (load {l:#010x})"))
            .unwrap_or_default();
        println!("  {:<16} {:#010x} {:>7} B{lma}", s.name, s.addr, s.size);
    }
    println!("application:");
    print_usage(&out.usage, &out.budget(), out.product);
    if let Some(boot) = &out.boot {
        println!("bootloader:");
        print_usage(&boot.program.usage, &image::BOOT_BUDGET, out.product);
    }

    let syms = symbols(&data, &sections)?;
    let named_flash: u64 = syms
        .iter()
        .filter(|s| matches!(s.place, Place::Flash | Place::FlashAndRam))
        .map(|s| s.size)
        .sum();
    println!();
    println!("per crate (symbols with a size; {named_flash} B of flash are in named symbols):");
    println!("  {:<28} {:>8} {:>8}", "crate", "flash", "RAM");
    for (k, f, r) in by_crate(&syms) {
        println!("  {k:<28} {f:>8} {r:>8}");
    }
    let mut largest = syms.clone();
    largest.sort_by(|a, b| b.size.cmp(&a.size).then(a.name.cmp(&b.name)));
    println!();
    println!("largest {} symbols:", args.top);
    for s in largest.iter().take(args.top) {
        let place = match s.place {
            Place::Flash => "flash",
            Place::FlashAndRam => "data",
            Place::Ram => "RAM",
            Place::AhbSram => "AHB",
            Place::None => "-",
        };
        let mut name = s.name.clone();
        if name.len() > 100 {
            name.truncate(97);
            name.push_str("...");
        }
        println!("  {:>7} {place:<5} {name}", s.size);
    }
    if args.by_function {
        print_code_by_function(&out.elf, &data, args.top)?;
    }
    // The verdict last, so the breakdown above is printed even when over budget.
    build::check_budget(&out)
}

/// The executable sections' address ranges (`start..end`).
fn code_ranges(data: &[u8]) -> Result<Vec<(u64, u64)>> {
    let file = object::File::parse(data).map_err(|e| format!("cannot read the ELF: {e}"))?;
    Ok(file
        .sections()
        .filter(|s| s.kind() == SectionKind::Text && s.size() > 0)
        .map(|s| (s.address(), s.address() + s.size()))
        .collect())
}

/// Bytes of `ranges` per owner ([`by_function::owner`]), looked up every halfword (a Thumb
/// instruction is one or two): the owners' bytes add up to the ranges' sizes. Largest first.
pub fn code_owners(
    ranges: &[(u64, u64)],
    symbols: &dyn Symbols,
    project: &[String],
) -> Vec<(String, u64)> {
    let mut per: BTreeMap<String, u64> = BTreeMap::new();
    for &(start, end) in ranges {
        let mut pc = start;
        while pc < end {
            let step = 2.min(end - pc);
            *per.entry(by_function::owner(pc, &symbols.frames(pc), project))
                .or_insert(0) += step;
            pc += step;
        }
    }
    let mut v: Vec<(String, u64)> = per.into_iter().collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    v
}

fn print_code_by_function(elf: &std::path::Path, data: &[u8], top: usize) -> Result {
    let project = by_function::workspace_crates()?;
    let dwarf = Dwarf::load(elf)?;
    let owners = code_owners(&code_ranges(data)?, &dwarf, &project);
    let total: u64 = owners.iter().map(|(_, n)| n).sum();
    let mut crates: BTreeMap<String, u64> = BTreeMap::new();
    for (f, n) in &owners {
        // The outliner's functions and the C/asm symbols have no path.
        let krate = match f.starts_with("OUTLINED_FUNCTION_") {
            true => "[outlined]".to_string(),
            false => crate_of(f, f.contains("::")),
        };
        *crates.entry(krate).or_insert(0) += n;
    }
    let mut crates: Vec<_> = crates.into_iter().collect();
    crates.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    println!();
    println!(
        "code per crate, inlined code counted to the function it was inlined from ({total} B):"
    );
    for (k, n) in &crates {
        println!("  {k:<28} {n:>8}");
    }
    println!();
    println!("largest {top} functions, inlined code counted likewise:");
    for (f, n) in owners.iter().take(top) {
        let mut name = f.clone();
        if name.len() > 100 {
            name.truncate(97);
            name.push_str("...");
        }
        println!("  {n:>7} {name}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crates_of_paths() {
        assert_eq!(
            crate_of("firmware::hw::spi::LegacySpi::exchange", true),
            "firmware"
        );
        assert_eq!(
            crate_of(
                "<firmware::hw::ssp::Ssp<S> as embedded_hal::spi::SpiBus>::write",
                true
            ),
            "firmware"
        );
        assert_eq!(crate_of("<&mut T as core::fmt::Debug>::fmt", true), "core");
        assert_eq!(crate_of("<&str as core::fmt::Display>::fmt", true), "core");
        assert_eq!(
            crate_of("<u32 as defmt::traits::Format>::format", true),
            "defmt"
        );
        assert_eq!(crate_of("core::fmt::write", true), "core");
        assert_eq!(crate_of("memcpy", false), "[unmangled]");
    }

    /// Frames by address range, innermost first.
    struct Fake(Vec<(u64, u64, Vec<&'static str>)>);

    impl Symbols for Fake {
        fn frames(&self, pc: u64) -> Vec<String> {
            self.0
                .iter()
                .find(|(s, e, _)| (*s..*e).contains(&pc))
                .map(|(_, _, f)| f.iter().map(|s| s.to_string()).collect())
                .unwrap_or_default()
        }
    }

    #[test]
    fn code_counts_to_the_inlining_workspace_function() {
        let symbols = Fake(vec![
            (
                0x100,
                0x108,
                vec!["core::option::Option<T>::map", "app::task"],
            ),
            (0x108, 0x110, vec!["lib::step", "app::task"]),
            (0x110, 0x113, vec!["compiler_builtins::memcpy"]),
        ]);
        let project = ["app".to_string(), "lib".to_string()];
        let owners = code_owners(&[(0x100, 0x113)], &symbols, &project);
        assert_eq!(
            owners,
            vec![
                ("app::task".to_string(), 8),
                ("lib::step".to_string(), 8),
                ("compiler_builtins::memcpy".to_string(), 3),
            ]
        );
        assert_eq!(owners.iter().map(|(_, n)| n).sum::<u64>(), 0x13);
    }

    #[test]
    fn grouping() {
        let s = |k: &str, size, place| Symbol {
            name: format!("{k}::x"),
            krate: k.into(),
            size,
            place,
        };
        let v = by_crate(&[
            s("a", 10, Place::Flash),
            s("b", 30, Place::Flash),
            s("a", 5, Place::FlashAndRam),
            s("a", 7, Place::Ram),
        ]);
        assert_eq!(v, vec![("b".into(), 30, 0), ("a".into(), 15, 12)]);
    }
}
