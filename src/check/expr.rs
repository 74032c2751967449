//! Conditions (`when …` of rules, shape parts and stage items) → IR expressions.

use super::MAX_QUANTIFIERS;
use super::lower::Checker;
use super::names::unknown;
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::{AttrRef, AttrType, CmpOp, Expr, KindId};
use crate::syntax::ast::{self, ExprKind, Ident};

/// What names an expression can see: variables bound by `exists` (with the kinds they may
/// stand for) and, in shape conditions, `self`.
#[derive(Debug, Default)]
pub(crate) struct Scope {
    /// Name, where it is bound, kinds.
    vars: Vec<(String, crate::ir::Span, Vec<KindId>)>,
    self_kinds: Option<Vec<KindId>>,
}

impl Scope {
    pub fn for_self(kinds: Vec<KindId>) -> Self {
        Scope { vars: Vec::new(), self_kinds: Some(kinds) }
    }
    /// The kinds a name stands for, and where it is bound (`None` for `self`).
    fn lookup(&self, name: &str) -> Option<(&Vec<KindId>, Option<crate::ir::Span>)> {
        if name == "self" {
            return self.self_kinds.as_ref().map(|k| (k, None));
        }
        self.vars.iter().rev().find(|(n, _, _)| n == name).map(|(_, s, k)| (k, Some(*s)))
    }
}

/// The variables bound around a point, quoted, outermost first.
fn bound_names(scope: &Scope) -> String {
    let own = scope.self_kinds.as_ref().map(|_| "self");
    let names: Vec<String> =
        own.into_iter().chain(scope.vars.iter().map(|(n, _, _)| n.as_str())).map(|n| format!("`{n}`")).collect();
    names.join(", ")
}

impl Checker<'_> {
    pub(crate) fn lower_expr(&mut self, e: &ast::Expr, scope: &mut Scope) -> Option<Expr> {
        match &e.kind {
            ExprKind::Bool(b) => Some(Expr::Bool(*b)),
            ExprKind::Not(inner) => Some(Expr::Not(Box::new(self.lower_expr(inner, scope)?))),
            ExprKind::And(terms) => self.lower_terms(terms, scope).map(Expr::And),
            ExprKind::Or(terms) => self.lower_terms(terms, scope).map(Expr::Or),
            ExprKind::Has(name) => match self.concepts.get(&name.name) {
                Some(&id) => {
                    self.refer(name, self.concepts.span(&name.name));
                    Some(Expr::Has(id))
                }
                None => {
                    let d = unknown("concept", name, self.concepts.names());
                    self.error(d);
                    None
                }
            },
            ExprKind::Exists { var, filter, cond } => {
                self.check_var_name(var)?;
                let bound = scope.vars.len() + usize::from(scope.self_kinds.is_some());
                if bound >= MAX_QUANTIFIERS {
                    // Evaluation visits entities^depth bindings: the bound keeps it polynomial.
                    self.error(
                        Diagnostic::error(
                            codes::TOO_MANY_QUANTIFIERS,
                            var.span,
                            format!("`exists {}` nests more than {MAX_QUANTIFIERS} quantifiers deep", var.name),
                        )
                        .with_label(format!("{} already bound here", bound_names(scope)))
                        .with_help("split the condition into several rules, or compare fewer entities at once"),
                    );
                    return None;
                }
                let f = self.lower_filter(filter);
                let kinds = self.matching_kinds(&f);
                scope.vars.push((var.name.clone(), var.span, kinds));
                let cond = cond.as_ref().map(|c| self.lower_expr(c, scope));
                scope.vars.pop();
                let cond = match cond {
                    Some(c) => Some(Box::new(c?)),
                    None => None,
                };
                Some(Expr::Exists { var: var.name.clone(), filter: f, cond })
            }
            ExprKind::Count { filter, op, n } => {
                Some(Expr::Count { filter: self.lower_filter(filter), op: *op, n: *n })
            }
            ExprKind::In { var, region } => {
                self.bound_var(var, scope)?;
                match self.regions.get(&region.name) {
                    Some(&r) => {
                        self.refer(region, self.regions.span(&region.name));
                        Some(Expr::InRegion { var: var.name.clone(), region: r })
                    }
                    None => {
                        let d = unknown("region", region, self.regions.names());
                        self.error(d);
                        None
                    }
                }
            }
            ExprKind::Cmp { path, op, value } => self.lower_cmp(path, *op, value, scope),
            ExprKind::CmpAttrs { left, op, right } => self.lower_cmp_attrs(left, *op, right, scope),
            ExprKind::Related { var, relation, to } => {
                let var_ok = self.bound_var(var, scope).is_some();
                let known = self.relations.get(&relation.name).is_some();
                if !known {
                    let d = unknown("relation", relation, self.relations.names());
                    self.error(d);
                }
                self.refer(relation, self.relations.span(&relation.name));
                let to = if to.name == "ego" {
                    None
                } else {
                    self.bound_var(to, scope)?;
                    Some(to.name.clone())
                };
                (var_ok && known).then(|| Expr::Related { var: var.name.clone(), relation: relation.name.clone(), to })
            }
        }
    }

    fn lower_terms(&mut self, terms: &[ast::Expr], scope: &mut Scope) -> Option<Vec<Expr>> {
        let lowered: Vec<Option<Expr>> = terms.iter().map(|t| self.lower_expr(t, scope)).collect();
        lowered.into_iter().collect()
    }

    fn check_var_name(&mut self, var: &Ident) -> Option<()> {
        if matches!(var.name.as_str(), "world" | "self" | "ego") {
            self.error(
                Diagnostic::error(codes::BAD_REFERENCE, var.span, format!("`{}` cannot be a variable name", var.name))
                    .with_label("reserved name")
                    .with_help("`world`, `self` and `ego` have fixed meanings; pick another name"),
            );
            return None;
        }
        Some(())
    }

    /// The kinds a variable may stand for, reporting an unbound one.
    fn bound_var(&mut self, var: &Ident, scope: &Scope) -> Option<Vec<KindId>> {
        if let Some((k, bound)) = scope.lookup(&var.name) {
            let k = k.clone();
            self.refer(var, bound);
            return Some(k);
        }
        let d = if var.name == "self" {
            Diagnostic::error(codes::BAD_REFERENCE, var.span, "`self` is only bound in shape conditions")
                .with_label("no entity here")
                .with_help("bind an entity with `exists e: KIND where …` and use `e.ATTR`")
        } else {
            Diagnostic::error(codes::BAD_REFERENCE, var.span, format!("unknown variable `{}`", var.name))
                .with_label("not bound here")
                .with_help(format!("bind it with `exists {}: KIND where …`", var.name))
        };
        self.error(d);
        None
    }

    fn lower_cmp(&mut self, path: &ast::Path, op: CmpOp, value: &ast::ValueLit, scope: &Scope) -> Option<Expr> {
        let (r, ty) = self.attr_ref(path, scope)?;
        let attr = &path.parts[1];
        if matches!(ty, AttrType::Bool | AttrType::Enum(_)) && !matches!(op, CmpOp::Eq | CmpOp::Ne) {
            let t = self.type_name(&ty);
            self.error(
                Diagnostic::error(
                    codes::TYPE_MISMATCH,
                    path.span,
                    format!("`{}` is {t} and can only be compared with `==` or `!=`", attr.name),
                )
                .with_label("ordered comparison of a non-number"),
            );
            return None;
        }
        // Thresholds may lie outside the attribute's bounds (`distance > 200m` is simply never
        // true), so compare against the type without its bounds.
        let unbounded = match &ty {
            AttrType::Number { dimension, .. } => {
                AttrType::Number { dimension: dimension.clone(), min: f64::MIN, max: f64::MAX }
            }
            other => other.clone(),
        };
        let value = self.lower_value(value, &unbounded, &attr.name)?;
        Some(Expr::Cmp { var: r.var, attr: r.attr, op, value })
    }

    /// `a.distance < b.distance`: both sides must have one type (numbers of one dimension, or
    /// one enum, or booleans); only numbers are ordered.
    fn lower_cmp_attrs(&mut self, left: &ast::Path, op: CmpOp, right: &ast::Path, scope: &Scope) -> Option<Expr> {
        let l = self.attr_ref(left, scope);
        let r = self.attr_ref(right, scope);
        let ((lr, lt), (rr, rt)) = (l?, r?);
        let span = super::lower::join(left.span, right.span);
        let text = |p: &ast::Path| p.parts.iter().map(|i| i.name.as_str()).collect::<Vec<_>>().join(".");
        let same = match (&lt, &rt) {
            (AttrType::Number { dimension: a, .. }, AttrType::Number { dimension: b, .. }) => {
                if a != b {
                    let (ta, tb) = (self.type_name(&lt), self.type_name(&rt));
                    self.error(
                        Diagnostic::error(
                            codes::DIMENSION_MISMATCH,
                            span,
                            format!("cannot compare `{}` ({ta}) with `{}` ({tb})", text(left), text(right)),
                        )
                        .with_label("different dimensions")
                        .with_help("compare attributes that measure the same thing"),
                    );
                    return None;
                }
                true
            }
            (AttrType::Bool, AttrType::Bool) => true,
            (AttrType::Enum(a), AttrType::Enum(b)) => a == b,
            _ => false,
        };
        if !same {
            let (ta, tb) = (self.type_name(&lt), self.type_name(&rt));
            self.error(
                Diagnostic::error(
                    codes::TYPE_MISMATCH,
                    span,
                    format!("cannot compare `{}` ({ta}) with `{}` ({tb})", text(left), text(right)),
                )
                .with_label("different types"),
            );
            return None;
        }
        if !matches!(lt, AttrType::Number { .. }) && !matches!(op, CmpOp::Eq | CmpOp::Ne) {
            let t = self.type_name(&lt);
            self.error(
                Diagnostic::error(
                    codes::TYPE_MISMATCH,
                    span,
                    format!(
                        "`{}` and `{}` are {t} and can only be compared with `==` or `!=`",
                        text(left),
                        text(right)
                    ),
                )
                .with_label("ordered comparison of non-numbers"),
            );
            return None;
        }
        Some(Expr::CmpAttrs { left: lr, op, right: rr })
    }

    /// Resolve `VAR.ATTR`, `world.ATTR` or `self.ATTR` to a reference and its type.
    fn attr_ref(&mut self, path: &ast::Path, scope: &Scope) -> Option<(AttrRef, AttrType)> {
        let [head, attr] = path.parts.as_slice() else {
            self.error(
                Diagnostic::error(codes::BAD_REFERENCE, path.span, "expected `VAR.ATTR`, `world.ATTR` or `self.ATTR`")
                    .with_label("cannot compare this")
                    .with_help("compare an attribute of an entity bound by `exists`, of `self`, or of the world"),
            );
            return None;
        };
        let (var, ty) = if head.name == "world" {
            match self.world_attrs.get(&attr.name) {
                Some(&i) => {
                    self.refer(attr, self.world_attrs.span(&attr.name));
                    (None, self.d.world[i].ty.clone())
                }
                None => {
                    let mut d = unknown("world attribute", attr, self.world_attrs.names());
                    d.code = codes::UNKNOWN_ATTR;
                    self.error(d);
                    return None;
                }
            }
        } else {
            let kinds = self.bound_var(head, scope)?;
            (Some(head.name.clone()), self.entity_attr_type(&kinds, attr)?)
        };
        Some((AttrRef { var, attr: attr.name.clone() }, ty))
    }

    /// The type of attribute `attr` on entities of `kinds`; it must exist on at least one.
    fn entity_attr_type(&mut self, kinds: &[KindId], attr: &Ident) -> Option<AttrType> {
        for k in kinds {
            let kind = &self.d.kinds[k.index()];
            if let Some(i) = kind.attr(&attr.name) {
                let (ty, decl) = (kind.attrs[i].ty.clone(), kind.attrs[i].span);
                self.refer(attr, Some(decl));
                return Some(ty);
            }
        }
        let mut names: Vec<&str> = Vec::new();
        for k in kinds {
            for a in &self.d.kinds[k.index()].attrs {
                if !names.contains(&a.name.as_str()) {
                    names.push(&a.name);
                }
            }
        }
        let mut d = unknown("attribute", attr, names.iter().copied()).with_label(if kinds.is_empty() {
            "no kind matches this entity's filter"
        } else {
            "no matching kind has it"
        });
        d.code = codes::UNKNOWN_ATTR;
        self.error(d);
        None
    }
}
