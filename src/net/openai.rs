//! What OpenAI's API host expects of every Revelio client that calls it (the VLM client
//! `vlm::openai` and the image generator `render::imagegen`).

pub const DEFAULT_BASE_URL: &str = "https://api.openai.com/v1";
