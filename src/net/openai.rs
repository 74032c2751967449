//! What OpenAI's API host expects of every Revelio client that calls it (the VLM client
//! `vlm::openai` and the image generator `render::imagegen`).

pub const DEFAULT_BASE_URL: &str = "https://api.openai.com/v1";

pub const HOST: super::Host =
    super::Host { provider: "openai", base_env: &["OPENAI_BASE_URL"], key_env: &["OPENAI_API_KEY"] };
