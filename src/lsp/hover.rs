//! Hover text: what a name declares, in the words of its declaration — a concept's
//! description, category and probe; a kind's attributes with their units and bounds (inherited
//! ones too); a rule's `///` rationale and what it expects; a unit's dimension; an attribute's
//! type, bounds and default.

use super::index::{Index, Sort, Symbol};

pub fn markdown(ix: &Index, id: usize) -> String {
    let s = &ix.symbols[id];
    let mut out = String::new();
    let code = |out: &mut String, text: &str| {
        out.push_str("```revelio\n");
        out.push_str(text.trim_end());
        out.push_str("\n```\n");
    };
    match s.sort {
        Sort::Kind | Sort::Tag => {
            let parents: Vec<&str> = ix.parents_of(id).iter().map(|&p| ix.symbols[p].name.as_str()).collect();
            let mut ancestors = ix.ancestors(id);
            ancestors.sort();
            let further: Vec<&str> = ancestors
                .iter()
                .filter(|a| !ix.parents_of(id).contains(a))
                .map(|&a| ix.symbols[a].name.as_str())
                .collect();
            let word = if s.sort == Sort::Kind { "kind" } else { "tag" };
            let head = if parents.is_empty() {
                format!("{word} {}", s.name)
            } else {
                format!("{word} {}: {}", s.name, parents.join(", "))
            };
            if s.sort == Sort::Kind {
                let mut body = head + " {\n";
                for a in ix.attrs_of_kind(id) {
                    let attr = &ix.symbols[a];
                    body.push_str("  ");
                    body.push_str(attr.snippet.trim());
                    if attr.parent != Some(id)
                        && let Some(owner) = attr.parent
                    {
                        body.push_str(&format!("  // from {}", ix.symbols[owner].name));
                    }
                    body.push('\n');
                }
                body.push('}');
                code(&mut out, &body);
            } else {
                code(&mut out, &head);
            }
            if !further.is_empty() {
                out.push_str(&format!("\nalso {}\n", further.join(", ")));
            }
        }
        Sort::Attr | Sort::WorldAttr => {
            let owner = s.parent.map_or("world".to_string(), |p| format!("kind {}", ix.symbols[p].name));
            code(&mut out, &format!("{}  // {owner}", s.snippet.trim()));
            if let Some(e) = ix.enum_of_attr(id) {
                let vs: Vec<String> = ix.variants_of(e).iter().map(|&v| ix.symbols[v].name.clone()).collect();
                out.push_str(&format!("\nvalues: {}\n", vs.join(", ")));
            }
        }
        Sort::Entity | Sort::Var => code(&mut out, &s.snippet),
        Sort::Module => out.push_str(&format!("module `{}`\n", s.name)),
        _ => code(&mut out, &s.snippet),
    }
    push_notes(&mut out, s);
    out
}

fn push_notes(out: &mut String, s: &Symbol) {
    if !s.doc.is_empty() {
        out.push('\n');
        out.push_str(&s.doc);
        out.push('\n');
    }
    for n in &s.notes {
        out.push('\n');
        out.push_str(n);
        out.push('\n');
    }
}
