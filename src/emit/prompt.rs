//! Image-generation prompt: a fixed framing sentence, then the concepts' `prompt` snippets in
//! concept index order (the paper concatenates the snippets). A concept without a snippet
//! contributes its `description`, so no concept of the set is silently left out of the image.
//! The prompt depends only on the concept set, not on the seed: image models draw their own
//! variation.

use crate::ir::Domain;
use crate::scene::Scene;

use super::EmitError;

/// Opening sentence of every prompt: the viewpoint the questions are asked from.
pub const FRAMING: &str = "A photorealistic photograph taken from the first-person point of view of the camera, \
showing exactly the following scene, with nothing else notable in view.";

/// The prompt of a sampled scene (its concepts looked up in `domain`).
pub fn prompt(domain: &Domain, scene: &Scene) -> Result<String, EmitError> {
    let mut out = String::from(FRAMING);
    for name in &scene.concepts {
        let c = domain
            .concept_by_name(name)
            .ok_or_else(|| EmitError(format!("concept `{name}` of the scene is not in domain `{}`", domain.name)))?;
        let snippet = c.render.prompt.as_deref().unwrap_or(&c.description).trim();
        if !snippet.is_empty() {
            out.push(' ');
            out.push_str(snippet);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::fixture::{set, tiny_domain};

    #[test]
    fn snippets_in_index_order_after_framing() {
        let d = tiny_domain();
        let scene = crate::sample::sample(&d, set(&d, &["near", "weather_hard_rain", "pedestrian"]), 0).unwrap();
        insta::assert_snapshot!(prompt(&d, &scene).unwrap(), @"A photorealistic photograph taken from the first-person point of view of the camera, showing exactly the following scene, with nothing else notable in view. A pedestrian stands ahead. Heavy rain falls. It is only a few meters away.");
    }

    #[test]
    fn falls_back_to_description_and_rejects_foreign_scenes() {
        let mut d = tiny_domain();
        d.concepts[0].render.prompt = None;
        let scene = crate::sample::sample(&d, set(&d, &["pedestrian"]), 0).unwrap();
        assert!(prompt(&d, &scene).unwrap().ends_with(" The pedestrian concept."));
        let mut foreign = scene.clone();
        foreign.concepts.push("unicorn".into());
        assert_eq!(
            prompt(&d, &foreign).unwrap_err().to_string(),
            "concept `unicorn` of the scene is not in domain `tiny`"
        );
    }
}
