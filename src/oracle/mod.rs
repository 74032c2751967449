//! Ground truth for a concept set (being built).
use crate::ir::{ConceptSet, Domain, QuestionId, RuleId};

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Verdict {
    pub question: QuestionId,
    pub expected: u32,
    pub rule: RuleId,
    pub explanation: String,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct OracleError(pub String);

pub fn evaluate(_domain: &Domain, _set: ConceptSet) -> Result<Verdict, OracleError> {
    unimplemented!("oracle::evaluate")
}
