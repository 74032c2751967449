//! The pest grammar (`grammar/revelio.pest`) and facts about its rules: which rules are keyword
//! tokens and what they spell, and which rule parses the item a keyword starts. The parser and
//! the formatter both walk the tree pest builds from these rules.

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/revelio.pest"]
pub struct RevParser;

pub fn is_keyword(r: Rule) -> bool {
    keyword_text(r).is_some()
}

/// The source text of a keyword rule.
pub fn keyword_text(r: Rule) -> Option<&'static str> {
    use Rule::*;
    Some(match r {
        kw_domain => "domain",
        kw_use => "use",
        kw_unit => "unit",
        kw_enum => "enum",
        kw_tag => "tag",
        kw_relation => "relation",
        kw_kind => "kind",
        kw_look => "look",
        kw_world => "world",
        kw_region => "region",
        kw_preset => "preset",
        kw_camera => "camera",
        kw_stage => "stage",
        kw_concept => "concept",
        kw_modifier => "modifier",
        kw_constraint => "constraint",
        kw_question => "question",
        kw_rules => "rules",
        kw_rule => "rule",
        kw_allow => "allow",
        kw_visible => "visible",
        kw_description => "description",
        kw_category => "category",
        kw_add => "add",
        kw_set => "set",
        kw_probe => "probe",
        kw_scenic => "scenic",
        kw_prompt => "prompt",
        kw_shape => "shape",
        kw_target => "target",
        kw_move => "move",
        kw_text => "text",
        kw_option => "option",
        kw_when => "when",
        kw_expect => "expect",
        kw_elements => "elements",
        kw_safe => "safe",
        kw_for => "for",
        kw_at => "at",
        kw_look_at => "look_at",
        kw_fov => "fov",
        kw_size => "size",
        kw_color => "color",
        kw_material => "material",
        kw_yaw => "yaw",
        kw_roll => "roll",
        kw_pitch => "pitch",
        kw_repeat => "repeat",
        kw_step => "step",
        kw_in => "in",
        kw_not => "not",
        kw_and => "and",
        kw_or => "or",
        kw_has => "has",
        kw_exists => "exists",
        kw_count => "count",
        kw_where => "where",
        kw_std => "std",
        _ => return None,
    })
}

/// The item keywords, for messages and recovery.
pub use super::lexer::ITEM_KEYWORDS;
