//! The diagnostics chapter's tables: every AL status code, SDO abort code, FoE error code,
//! mailbox error code and Emergency error code the firmware can send, found in its source.
//!
//! The firmware's crates are read with `syn` from their roots (the library, the application
//! and the bootloader binaries) along their `mod` declarations, as the LPC1754 build sees
//! them: modules and items under `cfg(test)` are skipped, `target_os = "none"` holds, and so
//! does every feature but the test-only `fake-esc`. In that code:
//!
//! - a code of an enum (`AlStatusCode::SyncManagerWatchdog`) used as a value counts as sent
//!   where it is used; a pattern (`match` arm, `matches!`) or a comparison (`==`, `!=`) does
//!   not: those only read a code;
//! - an Emergency error code is a `u16` constant named `EMCY_*` or declared in a module
//!   `emcy_code`; it counts when the code names it outside its declaration.
//!
//! The values, names and meanings come from the enums' declarations (`open_enum!` in
//! coe-core) and the constants' doc comments, so the tables cannot disagree with the code.

use crate::util::Result;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::path::{Path, PathBuf};
use syn::parse::{Parse, ParseStream};
use syn::punctuated::Punctuated;
use syn::visit::Visit;
use syn::{Attribute, Expr, Ident, Token};

/// The roots of the code that runs on the module: (crate name, root file from the project
/// root). coe-core is listed itself (the firmware links it); the drivers send none of
/// these codes.
const ROOTS: [(&str, &str); 4] = [
    ("coe_core", "coe-core/src/lib.rs"),
    ("firmware", "firmware/src/lib.rs"),
    ("application", "firmware/src/main.rs"),
    ("bootloader", "firmware/src/platform/bootloader/main.rs"),
];

/// The code families with a table each: (enum, heading, hex digits, what the code is).
const FAMILIES: [(&str, &str, usize, &str); 4] = [
    (
        "AlStatusCode",
        "AL status codes",
        4,
        "written to register 0x0134 with the error flag of the AL status (0x0130 bit 4) when \
         the module refuses a state change or leaves OP on its own; the master acknowledges it \
         by writing the AL control with bit 4 set",
    ),
    (
        "SdoAbortCode",
        "SDO abort codes",
        8,
        "the answer to an SDO request the module cannot serve, in an SDO abort (CoE and CAN \
         alike) or an SDO Information error",
    ),
    (
        "FoeErrorCode",
        "FoE error codes",
        4,
        "the FoE error packet that ends a file transfer the module refuses (firmware update)",
    ),
    (
        "MailboxErrorCode",
        "Mailbox error codes",
        4,
        "the mailbox error reply (mailbox type 0) to a frame whose mailbox header or protocol \
         the module cannot take",
    ),
];

/// The enum name the Emergency codes are listed under.
const EMERGENCY: &str = "Emergency";

/// One named code of a family.
#[derive(Debug, Clone, PartialEq)]
struct Code {
    value: u64,
    name: String,
    doc: String,
}

/// What the scan found.
#[derive(Debug, Default)]
struct Scan {
    /// Enum name -> its codes, in declaration order.
    declared: BTreeMap<String, Vec<Code>>,
    /// (enum name, variant) -> the places it is sent from.
    sent: BTreeMap<(String, String), BTreeSet<String>>,
    /// Emergency constants: (module path, name) -> code.
    emergencies: BTreeMap<(String, String), Code>,
    /// Paths used as values: last segment -> (the segment before it, place).
    values: BTreeMap<String, Vec<(Option<String>, String)>>,
}

/// The generated chapter body.
pub fn markdown(root: &Path) -> Result<String> {
    let scan = scan(root)?;
    render(&scan)
}

fn scan(root: &Path) -> Result<Scan> {
    let mut scan = Scan::default();
    for (krate, file) in ROOTS {
        let path = root.join(file);
        if !path.is_file() {
            return Err(format!(
                "docs: {} is not there: xtask/src/docs/error_codes.rs lists it as a root of \
                 the firmware's code",
                path.display()
            ));
        }
        walk(&mut scan, &path, krate.to_string(), true)?;
    }
    Ok(scan)
}

/// Reads one module file and the modules it declares.
fn walk(scan: &mut Scan, file: &Path, module: String, owns_dir: bool) -> Result {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let ast = syn::parse_file(&text).map_err(|e| format!("{}: {e}", file.display()))?;
    if !applies(&ast.attrs) {
        return Ok(());
    }
    // Where `mod x;` finds x: beside a lib.rs/main.rs/mod.rs, else in a folder named
    // after the file.
    let dir = if owns_dir {
        file.parent().map(Path::to_path_buf).unwrap_or_default()
    } else {
        file.with_extension("")
    };
    let mut visitor = Visitor::new(scan, module.clone());
    visitor.visit_file(&ast);
    let pending = std::mem::take(&mut visitor.modules);
    for (name, attrs) in pending {
        let (path, owns) = match path_attr(&attrs) {
            Some(p) => {
                let base = file.parent().unwrap_or(Path::new("."));
                let p = base.join(p);
                let owns = p.file_name().is_some_and(|n| n == "mod.rs");
                (p, owns)
            }
            None => {
                let flat = dir.join(format!("{name}.rs"));
                if flat.is_file() {
                    (flat, false)
                } else {
                    (dir.join(&name).join("mod.rs"), true)
                }
            }
        };
        walk(scan, &path, format!("{module}::{name}"), owns)?;
    }
    Ok(())
}

fn path_attr(attrs: &[Attribute]) -> Option<PathBuf> {
    attrs.iter().find_map(|a| {
        if !a.path().is_ident("path") {
            return None;
        }
        match &a.meta {
            syn::Meta::NameValue(nv) => match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => Some(PathBuf::from(s.value())),
                _ => None,
            },
            _ => None,
        }
    })
}

/// Whether code under `attrs` is in the module's build: no `#[test]`, and every `cfg`
/// true for the LPC1754 build (see the module documentation).
fn applies(attrs: &[Attribute]) -> bool {
    attrs.iter().all(|a| {
        if a.path().is_ident("test") {
            return false;
        }
        if !a.path().is_ident("cfg") {
            return true;
        }
        a.parse_args::<syn::Meta>().map_or(true, |m| cfg_holds(&m))
    })
}

fn cfg_holds(meta: &syn::Meta) -> bool {
    let name = meta
        .path()
        .get_ident()
        .map(Ident::to_string)
        .unwrap_or_default();
    match meta {
        syn::Meta::Path(_) => !matches!(name.as_str(), "test" | "doctest"),
        syn::Meta::NameValue(nv) => {
            let value = match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => s.value(),
                _ => String::new(),
            };
            match name.as_str() {
                "target_os" => value == "none",
                "target_arch" => value == "arm",
                "feature" => value != "fake-esc",
                _ => true,
            }
        }
        syn::Meta::List(list) => {
            let inner = list
                .parse_args_with(Punctuated::<syn::Meta, Token![,]>::parse_terminated)
                .map(|p| p.into_iter().collect::<Vec<_>>())
                .unwrap_or_default();
            match name.as_str() {
                "not" => !inner.iter().all(cfg_holds),
                "any" => inner.iter().any(cfg_holds),
                _ => inner.iter().all(cfg_holds),
            }
        }
    }
}

/// Walks one file: records declarations, sent codes and the modules it declares.
struct Visitor<'a> {
    scan: &'a mut Scan,
    module: String,
    /// Inline modules entered, below `module`.
    inner: Vec<String>,
    /// The type of the `impl` block we are in, and the function.
    impl_type: Option<String>,
    function: Option<String>,
    /// `mod x;` declarations of this file that apply: (name, attributes).
    modules: Vec<(String, Vec<Attribute>)>,
}

impl<'a> Visitor<'a> {
    fn new(scan: &'a mut Scan, module: String) -> Self {
        Self {
            scan,
            module,
            inner: Vec::new(),
            impl_type: None,
            function: None,
            modules: Vec::new(),
        }
    }

    fn module_path(&self) -> String {
        let mut path = self.module.clone();
        for m in &self.inner {
            path.push_str("::");
            path.push_str(m);
        }
        path
    }

    fn place(&self) -> String {
        let mut place = self.module_path();
        if let Some(t) = &self.impl_type {
            place.push_str("::");
            place.push_str(t);
        }
        if let Some(f) = &self.function {
            place.push_str("::");
            place.push_str(f);
        }
        place
    }

    fn value_path(&mut self, path: &syn::Path) {
        let segments: Vec<String> = path.segments.iter().map(|s| s.ident.to_string()).collect();
        let Some(last) = segments.last() else {
            return;
        };
        let before = segments.len().checked_sub(2).map(|i| segments[i].clone());
        let place = self.place();
        if let Some(family) = &before {
            if FAMILIES.iter().any(|f| f.0 == family) {
                self.scan
                    .sent
                    .entry((family.clone(), last.clone()))
                    .or_default()
                    .insert(place.clone());
            }
        }
        self.scan
            .values
            .entry(last.clone())
            .or_default()
            .push((before, place));
    }
}

impl<'ast> Visit<'ast> for Visitor<'_> {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs: &[Attribute] = match item {
            syn::Item::Const(i) => &i.attrs,
            syn::Item::Enum(i) => &i.attrs,
            syn::Item::Fn(i) => &i.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Macro(i) => &i.attrs,
            syn::Item::Mod(i) => &i.attrs,
            syn::Item::Static(i) => &i.attrs,
            syn::Item::Struct(i) => &i.attrs,
            syn::Item::Trait(i) => &i.attrs,
            syn::Item::Use(i) => &i.attrs,
            _ => &[],
        };
        if applies(attrs) {
            syn::visit::visit_item(self, item);
        }
    }

    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        let name = m.ident.to_string();
        match &m.content {
            None => self.modules.push((name, m.attrs.clone())),
            Some(_) => {
                self.inner.push(name);
                syn::visit::visit_item_mod(self, m);
                self.inner.pop();
            }
        }
    }

    fn visit_item_impl(&mut self, i: &'ast syn::ItemImpl) {
        let name = match &*i.self_ty {
            syn::Type::Path(p) => p.path.segments.last().map(|s| s.ident.to_string()),
            _ => None,
        };
        let outer = std::mem::replace(&mut self.impl_type, name);
        syn::visit::visit_item_impl(self, i);
        self.impl_type = outer;
    }

    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        if !applies(&f.attrs) {
            return;
        }
        let outer = self.function.replace(f.sig.ident.to_string());
        syn::visit::visit_impl_item_fn(self, f);
        self.function = outer;
    }

    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        let outer = self.function.replace(f.sig.ident.to_string());
        syn::visit::visit_trait_item_fn(self, f);
        self.function = outer;
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        let outer = self.function.replace(f.sig.ident.to_string());
        syn::visit::visit_item_fn(self, f);
        self.function = outer;
    }

    fn visit_item_const(&mut self, c: &'ast syn::ItemConst) {
        let name = c.ident.to_string();
        let in_emcy_module = self.inner.last().is_some_and(|m| m == "emcy_code");
        let is_u16 = matches!(&*c.ty, syn::Type::Path(p) if p.path.is_ident("u16"));
        if is_u16 && (name.starts_with("EMCY_") || in_emcy_module) {
            if let Some(value) = int_literal(&c.expr) {
                let key = (self.module_path(), name.clone());
                self.scan.emergencies.insert(
                    key,
                    Code {
                        value,
                        name,
                        doc: doc_text(&c.attrs),
                    },
                );
            }
        }
        syn::visit::visit_item_const(self, c);
    }

    fn visit_item_macro(&mut self, m: &'ast syn::ItemMacro) {
        if m.mac
            .path
            .segments
            .last()
            .is_some_and(|s| s.ident == "open_enum")
        {
            if let Ok(decl) = m.mac.parse_body::<OpenEnum>() {
                self.scan.declared.insert(decl.name, decl.codes);
            }
        }
    }

    fn visit_pat(&mut self, _: &'ast syn::Pat) {
        // A pattern (a `match` arm, `if let`) reads a code; it does not send one.
    }

    fn visit_expr_binary(&mut self, b: &'ast syn::ExprBinary) {
        // A comparison reads a code; it does not send one.
        if matches!(b.op, syn::BinOp::Eq(_) | syn::BinOp::Ne(_)) {
            return;
        }
        syn::visit::visit_expr_binary(self, b);
    }

    fn visit_expr_path(&mut self, p: &'ast syn::ExprPath) {
        self.value_path(&p.path);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        // The arguments of format-like and collection macros are expressions; `matches!`
        // and the assertions only read codes.
        let name = m
            .path
            .segments
            .last()
            .map(|s| s.ident.to_string())
            .unwrap_or_default();
        if name == "matches" || name.contains("assert") {
            return;
        }
        if let Ok(args) = m.parse_body_with(Punctuated::<Expr, Token![,]>::parse_terminated) {
            for e in &args {
                self.visit_expr(e);
            }
        }
    }
}

/// `open_enum! { #[doc] pub enum Name(u16) { #[doc] Variant = value, ... } }`.
struct OpenEnum {
    name: String,
    codes: Vec<Code>,
}

impl Parse for OpenEnum {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        input.call(Attribute::parse_outer)?;
        input.parse::<syn::Visibility>()?;
        input.parse::<Token![enum]>()?;
        let name: Ident = input.parse()?;
        let repr;
        syn::parenthesized!(repr in input);
        repr.parse::<syn::Type>()?;
        let body;
        syn::braced!(body in input);
        let mut codes = Vec::new();
        while !body.is_empty() {
            let attrs = body.call(Attribute::parse_outer)?;
            let variant: Ident = body.parse()?;
            body.parse::<Token![=]>()?;
            let value: Expr = body.parse()?;
            let value = int_literal(&value)
                .ok_or_else(|| syn::Error::new(variant.span(), "not an integer literal"))?;
            codes.push(Code {
                value,
                name: variant.to_string(),
                doc: doc_text(&attrs),
            });
            if body.is_empty() {
                break;
            }
            body.parse::<Token![,]>()?;
        }
        Ok(Self {
            name: name.to_string(),
            codes,
        })
    }
}

fn int_literal(e: &Expr) -> Option<u64> {
    match e {
        Expr::Lit(syn::ExprLit {
            lit: syn::Lit::Int(i),
            ..
        }) => i.base10_parse().ok(),
        _ => None,
    }
}

/// The doc comment, as one line.
fn doc_text(attrs: &[Attribute]) -> String {
    let lines: Vec<String> = attrs
        .iter()
        .filter(|a| a.path().is_ident("doc"))
        .filter_map(|a| match &a.meta {
            syn::Meta::NameValue(nv) => match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => Some(s.value().trim().to_string()),
                _ => None,
            },
            _ => None,
        })
        .collect();
    lines.join(" ").trim().to_string()
}

/// Text safe inside a table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// The places as a cell: the first few, and how many more.
fn places(set: &BTreeSet<String>) -> String {
    const SHOWN: usize = 3;
    let mut text = set
        .iter()
        .take(SHOWN)
        .map(|p| format!("`{p}`"))
        .collect::<Vec<_>>()
        .join(", ");
    if set.len() > SHOWN {
        let _ = write!(text, " and {} more", set.len() - SHOWN);
    }
    text
}

fn render(scan: &Scan) -> Result<String> {
    let mut out = String::new();
    for (family, heading, digits, what) in FAMILIES {
        let declared = scan.declared.get(family).ok_or_else(|| {
            format!("docs: no open_enum! declaration of {family} found in the firmware's code")
        })?;
        let sent: Vec<(&Code, &BTreeSet<String>)> = declared
            .iter()
            .filter_map(|c| {
                scan.sent
                    .get(&(family.to_string(), c.name.clone()))
                    .map(|p| (c, p))
            })
            .collect();
        let _ = writeln!(out, "## {heading}\n");
        let _ = writeln!(
            out,
            "`{family}`: {what}. The module sends {} of the {} codes the specification \
             lists.\n",
            sent.len(),
            declared.len()
        );
        out.push_str("| Code | Name | Meaning | Sent from |\n|---|---|---|---|\n");
        for (code, at) in sent {
            let _ = writeln!(
                out,
                "| `{:#0width$X}` | {} | {} | {} |",
                code.value,
                code.name,
                cell(&code.doc),
                places(at),
                width = digits + 2
            );
        }
        out.push('\n');
    }
    let mut emergencies: Vec<(&Code, BTreeSet<String>, &String)> = scan
        .emergencies
        .iter()
        .filter_map(|((module, name), code)| {
            let in_module = module.ends_with("::emcy_code");
            let at: BTreeSet<String> = scan
                .values
                .get(name)
                .into_iter()
                .flatten()
                .filter(|(before, _)| !in_module || before.as_deref() == Some("emcy_code"))
                .map(|(_, place)| place.clone())
                .collect();
            (!at.is_empty()).then_some((code, at, module))
        })
        .collect();
    emergencies.sort_by_key(|e| e.0.value);
    let _ = writeln!(out, "## Emergency error codes\n");
    let _ = writeln!(
        out,
        "The error code of an Emergency ({EMERGENCY} on EtherCAT, EMCY on CAN; CiA 301 table \
         21), with the error register 0x1001 and five bytes of detail; each is also recorded in \
         the error history 0x1003. {} codes.\n",
        emergencies.len()
    );
    out.push_str("| Code | Constant | Meaning | Sent from |\n|---|---|---|---|\n");
    for (code, at, module) in emergencies {
        let _ = writeln!(
            out,
            "| `{:#06X}` | `{module}::{}` | {} | {} |",
            code.value,
            code.name,
            cell(&code.doc),
            places(&at)
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use coe_core::wire::{FoeErrorCode, MailboxErrorCode};
    use coe_core::{AlStatusCode, SdoAbortCode};

    fn project() -> Scan {
        scan(&crate::util::root()).unwrap()
    }

    /// The values read from the source are the compiled enums' values: each code's name
    /// is the `Debug` name of the value converted back.
    #[test]
    fn declarations_agree_with_the_compiled_enums() {
        let s = project();
        let check = |family: &str, name_of: &dyn Fn(u64) -> String| {
            let codes = &s.declared[family];
            assert!(!codes.is_empty(), "{family}");
            for c in codes {
                assert_eq!(name_of(c.value), c.name, "{family} {:#x}", c.value);
                assert!(!c.doc.is_empty(), "{family}::{} has no doc", c.name);
            }
        };
        check("AlStatusCode", &|v| {
            format!("{:?}", AlStatusCode::from(v as u16))
        });
        check("SdoAbortCode", &|v| {
            format!("{:?}", SdoAbortCode::from(v as u32))
        });
        check("FoeErrorCode", &|v| {
            format!("{:?}", FoeErrorCode::from(v as u32))
        });
        check("MailboxErrorCode", &|v| {
            format!("{:?}", MailboxErrorCode::from(v as u16))
        });
    }

    /// Codes the fault campaign's tests see the module send are in the tables; codes only
    /// tests name, or only compared, are not.
    #[test]
    fn finds_what_the_firmware_sends_and_nothing_else() {
        let s = project();
        let sent = |f: &str, n: &str| s.sent.contains_key(&(f.to_string(), n.to_string()));
        assert!(sent("AlStatusCode", "SyncManagerWatchdog"));
        assert!(sent("AlStatusCode", "DcInvalidSyncCycleTime"));
        assert!(sent("AlStatusCode", "NoValidFirmware"), "the bootloader's");
        assert!(sent("SdoAbortCode", "ToggleBitNotAlternated"));
        assert!(sent("FoeErrorCode", "InvalidChecksum"));
        assert!(!sent("AlStatusCode", "TemperatureTooHigh"));
        let md = render(&s).unwrap();
        for code in ["`0x8250`", "`0x8700`", "`0x5000`", "`0xFF01`", "`0x8130`"] {
            assert!(md.contains(code), "Emergency {code} missing");
        }
    }

    #[test]
    fn cfg_follows_the_firmware_build() {
        let holds = |s: &str| cfg_holds(&syn::parse_str::<syn::Meta>(s).unwrap());
        assert!(!holds("test"));
        assert!(holds("not(test)"));
        assert!(!holds("any(test, feature = \"fake-esc\")"));
        assert!(holds("all(target_os = \"none\", feature = \"rtt\")"));
        assert!(!holds("not(target_os = \"none\")"));
    }
}
