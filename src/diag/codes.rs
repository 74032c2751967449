//! Stable codes of the front end's diagnostics (`R0001`–`R0099`). `docs/diagnostics.md` holds the
//! same table with an example for each; a test checks that the two agree and that every code
//! the checker emits is listed here.

/// A documented diagnostic code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CodeInfo {
    pub code: &'static str,
    pub name: &'static str,
    pub meaning: &'static str,
}

macro_rules! codes {
    ($($id:ident = $code:literal, $name:literal, $meaning:literal;)*) => {
        $(pub const $id: &str = $code;)*
        /// Every front-end code, in code order.
        pub const CODES: &[CodeInfo] = &[$(CodeInfo { code: $code, name: $name, meaning: $meaning }),*];
    };
}

codes! {
    SYNTAX = "R0001", "syntax-error", "the text does not follow the grammar";
    INVALID_LITERAL = "R0002", "invalid-literal", "a malformed literal: string escape, colour, number or image size";
    TOO_DEEP = "R0003", "nesting-too-deep", "the input nests too deeply to parse";
    FILE_TOO_LARGE = "R0004", "file-too-large", "a `.rev` file over 1 MiB, or a domain whose files pass 8 MiB together";
    UNKNOWN_MODULE = "R0010", "unknown-module", "`use std::NAME` names no standard-library module";
    FILE_NOT_FOUND = "R0011", "file-not-found", "`use \"PATH\"` names a file that cannot be read";
    MISPLACED_DOMAIN = "R0012", "misplaced-domain", "a `domain` line in a used module, or two `domain` lines";
    USE_REFUSED = "R0013", "use-refused", "`use \"PATH\"` names a file a domain may not read: outside its folder, not a `.rev` file, or not a regular file";
    UNKNOWN_NAME = "R0020", "unknown-name", "a name that is declared nowhere";
    DUPLICATE_NAME = "R0021", "duplicate-name", "a name declared twice in the same namespace";
    WRONG_SORT = "R0022", "wrong-sort-of-name", "a name of the wrong sort (e.g. an enum where a kind is expected)";
    UNKNOWN_ATTR = "R0023", "unknown-attribute", "an attribute that the kind or the world does not have";
    UNKNOWN_VARIANT = "R0024", "unknown-variant", "a value that is no variant of the attribute's enum";
    UNKNOWN_UNIT = "R0025", "unknown-unit", "a number with a unit suffix that no `unit` declares";
    CYCLE = "R0026", "inheritance-cycle", "a tag or kind that is its own ancestor";
    AMBIGUOUS_INHERITANCE = "R0027", "ambiguous-inheritance", "a kind that inherits two different `visible` overrides, or two different looks, from equally near parents";
    TYPE_MISMATCH = "R0030", "type-mismatch", "a value of the wrong type (number for a bool, range where one number is needed, …)";
    DIMENSION_MISMATCH = "R0031", "dimension-mismatch", "a number whose unit measures the wrong dimension";
    OUT_OF_RANGE = "R0032", "out-of-range", "a value outside the attribute's `in MIN..MAX` bounds";
    EMPTY_RANGE = "R0033", "empty-range", "a range `a..b` with `a > b`";
    TOO_MANY_QUANTIFIERS = "R0034", "too-many-quantifiers", "a condition that nests more than 3 `exists` (a shape condition's `self` counts as one)";
    COUNT_TOO_LARGE = "R0035", "count-too-large", "a count past its bound: `repeat` over 1 000, over 4 096 stage parts with repeats, over 256 parts in one block, over 128 entities added";
    DRAWS_NOTHING = "R0036", "draws-nothing", "(warning) a kind that a concept places but that has no look, own or inherited, or a `look` on a kind that nothing places";
    INEFFECTIVE_MODIFIER = "R0037", "ineffective-modifier", "(warning) a modifier whose `set` cannot hold for a kind it targets (outside the attribute's bounds on that kind, or a `distance`/`lateral` range outside the region the entity stands in), or that changes nothing on any entity it can land on";
    MISPLACED_STATEMENT = "R0040", "misplaced-statement", "a statement where it means nothing (`move` in a concept, `add` in a modifier, …)";
    MISSING_STATEMENT = "R0041", "missing-statement", "a required statement is missing (a modifier's `target`, a rule's `expect`, a shape part's `size`, …)";
    DUPLICATE_STATEMENT = "R0042", "duplicate-statement", "a statement or setting given twice where only one counts";
    MISSING_TEXT = "R0043", "missing-text", "(warning) a concept without `description` or `probe`";
    TOO_MANY_CONCEPTS = "R0044", "too-many-concepts", "more concepts than a concept set can hold (512)";
    PARTIAL_TARGET = "R0045", "partial-target-attribute", "(warning) a modifier sets an attribute that some of its target kinds lack";
    DUPLICATE_LOOK = "R0046", "duplicate-look", "a kind with both `shape { … }` and a `look`, or two `look`s";
    RELATION_PLACEMENT = "R0047", "relation-placement", "a relation whose placement is missing, unknown or contradictory";
    UNPLACEABLE_RELATION = "R0048", "unplaceable-relation", "an `add` whose relation can never hold: its region is out of reach of its target, or the entities are placed relative to each other in a cycle";
    REGION_NOT_ALLOWED = "R0049", "region-not-allowed", "an entity added to or moved into a region its kind may not stand in";
    EMPTY_MEMBER = "R0050", "empty-member", "a constraint wildcard or category that matches no concept";
    UNKNOWN_CONSTRAINT = "R0051", "unknown-constraint", "a constraint that is not `exclusive`, `at_most`, `requires` or `forbids`";
    CONSTRAINT_ARITY = "R0052", "constraint-arity", "a constraint with the wrong number of members or a missing count";
    RULES_BLOCK = "R0060", "rules-block", "a domain without a `rules` block, or with more than one";
    MIXED_QUESTIONS = "R0061", "mixed-questions", "`priority` rules that expect options of different questions";
    UNKNOWN_SELECTION = "R0062", "unknown-selection", "a `rules` block whose selection is not `priority` or `best_fit`";
    BAD_REFERENCE = "R0063", "bad-reference", "a reference that is not `VAR.attr`, `world.attr` or `self.attr`, or an unbound variable";
    BAD_ALLOW = "R0064", "invalid-allow", "`allow` of a code that is not a lattice lint (`R0100`–`R0199`)";
    ALLOW_WITHOUT_REASON = "R0065", "allow-without-reason", "(warning) an `allow` with no `///` comment saying why";
    LATTICE_TOO_LARGE = "R0070", "lattice-too-large", "more valid concept sets than the limit (`--max-sets`, 1 000 000 by default)";
}

/// The documented entry of a code.
pub fn info(code: &str) -> Option<&'static CodeInfo> {
    CODES.iter().find(|c| c.code == code)
}
