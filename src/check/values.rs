//! Attribute declarations and values: types, units and dimensions, bounds, enum variants.
//! Every number is converted to its dimension's base unit here.

use super::lower::{Checker, TypeSym, join};
use super::names::{Namespace, unknown};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;
use crate::syntax::ast::{self, Num, ValueLit};

impl Checker<'_> {
    /// Lower `NAME: TYPE [in MIN..MAX] = DEFAULT` declarations; duplicates are reported.
    pub(super) fn lower_attrs(&mut self, attrs: &[ast::AttrDecl]) -> Vec<AttrDef> {
        let mut seen = Namespace::<()>::default();
        let mut out = Vec::new();
        for a in attrs {
            if !seen.declare(&a.name, (), |_| "an attribute of the same owner", &mut self.diags) {
                continue;
            }
            if let Some(def) = self.lower_attr(a) {
                out.push(def);
            }
        }
        out
    }

    pub(super) fn lower_attr(&mut self, a: &ast::AttrDecl) -> Option<AttrDef> {
        let ty = self.attr_type(a)?;
        // A bad default is reported; the attribute still exists, so uses of it are checked
        // instead of failing as unknown.
        let default = self.lower_value(&a.default, &ty, &a.name.name).unwrap_or_else(|| placeholder(&ty));
        Some(AttrDef { name: a.name.name.clone(), ty, default, doc: a.doc.clone(), span: a.span })
    }

    fn attr_type(&mut self, a: &ast::AttrDecl) -> Option<AttrType> {
        let ty_name = a.ty.name.as_str();
        let dimension = if ty_name == "number" {
            Some(String::new())
        } else if self.d.units.iter().any(|u| u.dimension == ty_name) {
            Some(ty_name.to_string())
        } else {
            None
        };
        let ty = match (ty_name, dimension) {
            ("bool", _) => AttrType::Bool,
            (_, Some(dimension)) => {
                let (min, max) = match &a.bounds {
                    None => (f64::MIN, f64::MAX),
                    Some((lo, hi)) => {
                        let lo = self.number(lo, &dimension);
                        let hi = self.number(hi, &dimension);
                        let (lo, hi) = (lo?, hi?);
                        if lo > hi {
                            let span = join(a.bounds.as_ref().map(|b| b.0.span)?, a.bounds.as_ref().map(|b| b.1.span)?);
                            self.error(empty_range(span));
                            return None;
                        }
                        (lo, hi)
                    }
                };
                AttrType::Number { dimension, min, max }
            }
            _ => match self.types.get(ty_name) {
                Some(&TypeSym::Enum(e)) => {
                    self.refer(&a.ty, self.types.span(ty_name));
                    AttrType::Enum(e)
                }
                Some(other) => {
                    let sort = other.sort();
                    self.error(
                        Diagnostic::error(codes::WRONG_SORT, a.ty.span, format!("`{ty_name}` is {sort}, not a type"))
                            .with_label("expected a type")
                            .with_help(
                                "attribute types are `bool`, `number`, a dimension such as `length`, or an enum",
                            ),
                    );
                    return None;
                }
                None => {
                    let mut candidates: Vec<&str> = vec!["bool", "number"];
                    candidates.extend(self.d.units.iter().map(|u| u.dimension.as_str()));
                    candidates.extend(self.d.enums.iter().map(|e| e.name.as_str()));
                    let d =
                        unknown("type", &a.ty, candidates).with_label("not `bool`, `number`, a dimension or an enum");
                    self.error(d);
                    return None;
                }
            },
        };
        if a.bounds.is_some() && !matches!(ty, AttrType::Number { .. }) {
            let span = a.bounds.as_ref().map(|b| join(b.0.span, b.1.span))?;
            self.error(
                Diagnostic::error(
                    codes::TYPE_MISMATCH,
                    span,
                    format!("only numeric attributes take bounds, `{}` does not", a.name.name),
                )
                .with_label("remove these bounds"),
            );
            return None;
        }
        Some(ty)
    }

    /// Convert a number to the base unit of `dimension` (`""`: a plain number).
    pub fn number(&mut self, n: &Num, dimension: &str) -> Option<f64> {
        let (found, scale) = match &n.unit {
            None => (String::new(), 1.0),
            Some(u) => match self.units.get(&u.name) {
                Some(info) => {
                    let found = (info.dimension.clone(), info.scale);
                    self.refer(u, self.units.span(&u.name));
                    found
                }
                None => {
                    let d = Diagnostic::error(codes::UNKNOWN_UNIT, u.span, format!("unknown unit `{}`", u.name))
                        .with_label("no `unit` declares this suffix");
                    let d = match crate::diag::suggest::suggest(&u.name, self.units.names()) {
                        Some(s) => d.with_help(format!("did you mean `{s}`?")),
                        None => d.with_help("declare it with `unit NAME: DIMENSION = SCALE`"),
                    };
                    self.error(d);
                    return None;
                }
            },
        };
        if found != dimension {
            self.error(dimension_mismatch(n, dimension, &found, self.example_unit(dimension)));
            return None;
        }
        Some(n.value * scale)
    }

    fn example_unit(&self, dimension: &str) -> Option<String> {
        self.d.units.iter().find(|u| u.dimension == dimension && u.scale == 1.0).map(|u| u.name.clone())
    }

    /// Type-check a value literal against an attribute type, converting it to the IR.
    pub fn lower_value(&mut self, v: &ValueLit, ty: &AttrType, attr: &str) -> Option<Value> {
        match (ty, v) {
            (AttrType::Bool, ValueLit::Bool(b, _)) => Some(Value::Bool(*b)),
            (AttrType::Enum(e), ValueLit::Name(n)) => {
                let def = &self.d.enums[e.index()];
                match def.variants.iter().position(|x| *x == n.name) {
                    Some(i) => {
                        let decl = self.variant_spans.get(e.index()).and_then(|v| v.get(i)).copied();
                        self.refer(n, decl);
                        Some(Value::Enum(*e, i as u32))
                    }
                    None => {
                        let d = Diagnostic::error(
                            codes::UNKNOWN_VARIANT,
                            n.span,
                            format!("`{}` is not a variant of enum `{}`", n.name, def.name),
                        )
                        .with_label(format!("`{attr}` is a `{}`", def.name));
                        let d = match crate::diag::suggest::suggest(&n.name, def.variants.iter().map(String::as_str)) {
                            Some(s) => d.with_help(format!("did you mean `{s}`?")),
                            None => d.with_help(format!("the variants are: {}", def.variants.join(", "))),
                        };
                        self.error(d);
                        None
                    }
                }
            }
            (AttrType::Number { dimension, min, max }, ValueLit::Num(n)) => {
                let x = self.number(n, dimension)?;
                self.check_bounds(x, x, *min, *max, n.span, attr)?;
                Some(Value::Number(x))
            }
            (AttrType::Number { dimension, min, max }, ValueLit::Range(a, b)) => {
                let lo = self.number(a, dimension);
                let hi = self.number(b, dimension);
                let (lo, hi) = (lo?, hi?);
                if lo > hi {
                    self.error(empty_range(v.span()));
                    return None;
                }
                self.check_bounds(lo, hi, *min, *max, v.span(), attr)?;
                Some(Value::Range(lo, hi))
            }
            _ => {
                let expected = self.type_name(ty);
                self.error(
                    Diagnostic::error(
                        codes::TYPE_MISMATCH,
                        v.span(),
                        format!("`{attr}` is {expected}, but this is {}", value_sort(v)),
                    )
                    .with_label(format!("expected {expected}")),
                );
                None
            }
        }
    }

    fn check_bounds(&mut self, lo: f64, hi: f64, min: f64, max: f64, span: Span, attr: &str) -> Option<()> {
        if lo < min || hi > max {
            self.error(
                Diagnostic::error(codes::OUT_OF_RANGE, span, format!("value is outside the range of `{attr}`"))
                    .with_label(format!("not within {}..{}", fmt_num(min), fmt_num(max)))
                    .with_help(format!("`{attr}` is declared `in {}..{}` (base units)", fmt_num(min), fmt_num(max))),
            );
            return None;
        }
        Some(())
    }

    pub fn type_name(&self, ty: &AttrType) -> String {
        match ty {
            AttrType::Bool => "a `bool`".to_string(),
            AttrType::Number { dimension, .. } if dimension.is_empty() => "a plain `number`".to_string(),
            AttrType::Number { dimension, .. } => format!("a `{dimension}`"),
            AttrType::Enum(e) => format!("a `{}`", self.d.enums[e.index()].name),
        }
    }

    /// A length triple `(x, y, z)` in metres.
    pub fn vec3(&mut self, v: &[Num; 3], dimension: &str) -> Option<[f64; 3]> {
        let x = self.number(&v[0], dimension);
        let y = self.number(&v[1], dimension);
        let z = self.number(&v[2], dimension);
        Some([x?, y?, z?])
    }
}

pub(super) fn empty_range(span: Span) -> Diagnostic {
    Diagnostic::error(codes::EMPTY_RANGE, span, "the range is empty: its start is above its end")
        .with_label("empty range")
        .with_help("write ranges low to high, `a..b` with `a <= b`")
}

/// A value of the type, standing in for a default that had an error (never reaches the IR).
fn placeholder(ty: &AttrType) -> Value {
    match ty {
        AttrType::Bool => Value::Bool(false),
        AttrType::Enum(e) => Value::Enum(*e, 0),
        AttrType::Number { min, max, .. } => Value::Number(0f64.clamp(*min, *max)),
    }
}

/// "a `length`", "an `angle`".
fn a_dim(dim: &str) -> String {
    let article = if dim.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} `{dim}`")
}

fn dimension_mismatch(n: &Num, expected: &str, found: &str, example: Option<String>) -> Diagnostic {
    let written = match &n.unit {
        Some(u) => format!("{}{}", fmt_num(n.value), u.name),
        None => fmt_num(n.value),
    };
    let (message, help) = match (expected.is_empty(), found.is_empty()) {
        (true, _) => {
            (format!("expected a plain number, found `{written}` ({})", a_dim(found)), "remove the unit".to_string())
        }
        (false, true) => (
            format!("expected {}, found `{written}` with no unit", a_dim(expected)),
            match example {
                Some(u) => format!("add {} unit, e.g. `{written}{u}`", a_dim(expected)),
                None => format!("add {} unit", a_dim(expected)),
            },
        ),
        (false, false) => (
            format!("expected {}, found `{written}` ({})", a_dim(expected), a_dim(found)),
            match example {
                Some(u) => format!("use {} unit such as `{u}`", a_dim(expected)),
                None => format!("use {} unit", a_dim(expected)),
            },
        ),
    };
    Diagnostic::error(codes::DIMENSION_MISMATCH, n.span, message)
        .with_label(if expected.is_empty() {
            "expected a plain number".to_string()
        } else {
            format!("expected {}", a_dim(expected))
        })
        .with_help(help)
}

fn value_sort(v: &ValueLit) -> &'static str {
    match v {
        ValueLit::Num(n) if n.unit.is_some() => "a number with a unit",
        ValueLit::Num(_) => "a number",
        ValueLit::Range(..) => "a range",
        ValueLit::Bool(..) => "a boolean",
        ValueLit::Name(_) => "a name",
    }
}

/// A number for messages: integers without a fraction, huge bounds as `…`.
pub(crate) fn fmt_num(x: f64) -> String {
    if x <= f64::MIN / 2.0 || x >= f64::MAX / 2.0 {
        "…".to_string()
    } else if x == x.trunc() && x.abs() < 1e15 {
        format!("{}", x as i64)
    } else {
        format!("{x}")
    }
}
