//! Image-generation renderers: `imagegen:gemini:MODEL` (generateContent with
//! `responseModalities: ["IMAGE"]`, the image as `inlineData`) and `imagegen:openai:MODEL`
//! (`POST /images/generations`, `b64_json`). Fed by the scene's image prompt, with the VLM
//! clients' resilience (`net::http`), a content-addressed image cache, and blocks and refusals
//! reported as blocked images (the observation's outcome `image_blocked`), never retried.

use std::io::Cursor;
use std::sync::Arc;
use std::time::Duration;

use base64::Engine;
use serde_json::{Value, json};

use crate::hash::parts_hex;
use crate::net::cache::Store;
use crate::net::http::{self, Gate, Limits, Request, Response, Transport, Verdict, snippet};
use crate::net::json as json_at;
use crate::net::secret::{Secret, redact};
use crate::net::{BoxFuture, EndpointFlags, gemini, openai};
use crate::render::{RenderError, Rendered, Renderer, RendererOptions};
use crate::scene::Scene;

/// The largest image-generation reply read: a 1536×1024 PNG is 3–4 MB as base64.
pub const MAX_IMAGE_REPLY: usize = 32 << 20;

enum Provider {
    Gemini { url: String, key: Option<Secret> },
    OpenAi { url: String, model: String, key: Option<Secret> },
}

pub struct ImageGen {
    id: String,
    provider: Provider,
    transport: Transport,
    cache: Option<Store>,
    size: Option<(u32, u32)>,
}

/// Build from `imagegen:PROVIDER:MODEL`.
pub fn build(spec: &str, opts: &RendererOptions) -> Result<Arc<dyn Renderer>, String> {
    let rest = spec.strip_prefix("imagegen:").unwrap_or(spec);
    let (provider, model) = rest.split_once(':').unwrap_or((rest, ""));
    if model.is_empty() {
        return Err(format!("invalid renderer `{spec}`: expected `imagegen:gemini:MODEL` or `imagegen:openai:MODEL`"));
    }
    if let Some((w, h)) = opts.size
        && (w == 0 || h == 0)
    {
        return Err(format!("invalid image size {w}x{h}: expected positive width and height"));
    }
    // The renderer's own endpoint: `--renderer-base-url` or its provider's variables, never the
    // model's `--base-url`, so each key goes only to its own provider's host.
    let base = EndpointFlags { base_url: opts.base_url.as_deref(), allow_http: opts.allow_http, dry_run: opts.dry_run };
    let (provider, endpoint) = match provider {
        "gemini" => {
            let e = gemini::HOST.endpoint(spec, base, gemini::DEFAULT_BASE_URL)?;
            (Provider::Gemini { url: gemini::endpoint(&e.base, model), key: e.key }, e.base)
        }
        "openai" => {
            let e = openai::HOST.endpoint(spec, base, openai::DEFAULT_BASE_URL)?;
            let url = format!("{}/images/generations", e.base);
            (Provider::OpenAi { url, model: model.to_string(), key: e.key }, e.base)
        }
        other => {
            return Err(format!(
                "unknown image-generation provider `{other}` in `{spec}`: expected `gemini` or `openai`"
            ));
        }
    };
    let gate = Gate::shared(&format!("imagegen {endpoint}"), 8, None);
    // A high-quality image takes a minute or two; its base64 reply a few MB.
    let mut limits = Limits::new(Duration::from_secs(300), 5, Duration::from_secs(900));
    limits.max_body = MAX_IMAGE_REPLY;
    let id = match opts.size {
        Some((w, h)) => format!("{spec}@{w}x{h}"),
        None => spec.to_string(),
    };
    let (name, key) = match &provider {
        Provider::Gemini { key, .. } => ("gemini imagegen", key),
        Provider::OpenAi { key, .. } => ("openai imagegen", key),
    };
    let secrets: Vec<&str> = key.iter().map(|k| k.0.as_str()).collect();
    let transport = Transport::new(gate, limits)?.labelled(name, &id, &secrets);
    Ok(Arc::new(ImageGen {
        id,
        provider,
        transport,
        cache: opts.cache_dir.as_ref().map(|d| Store::new(d, "png")),
        size: opts.size,
    }))
}

/// The Gemini aspect ratio closest to the requested size.
fn aspect_ratio((w, h): (u32, u32)) -> &'static str {
    const RATIOS: [(&str, f64); 10] = [
        ("1:1", 1.0),
        ("2:3", 2.0 / 3.0),
        ("3:2", 1.5),
        ("3:4", 0.75),
        ("4:3", 4.0 / 3.0),
        ("4:5", 0.8),
        ("5:4", 1.25),
        ("9:16", 9.0 / 16.0),
        ("16:9", 16.0 / 9.0),
        ("21:9", 21.0 / 9.0),
    ];
    let r = f64::from(w) / f64::from(h);
    RATIOS.iter().min_by(|a, b| (a.1.ln() - r.ln()).abs().total_cmp(&(b.1.ln() - r.ln()).abs())).map_or("1:1", |x| x.0)
}

/// OpenAI image sizes: landscape, portrait or square.
fn openai_size(size: Option<(u32, u32)>) -> &'static str {
    match size {
        Some((w, h)) if w * 4 > h * 5 => "1536x1024",
        Some((w, h)) if h * 4 > w * 5 => "1024x1536",
        _ => "1024x1024",
    }
}

impl ImageGen {
    fn secrets(&self) -> Vec<&str> {
        match &self.provider {
            Provider::Gemini { key, .. } | Provider::OpenAi { key, .. } => key.iter().map(|k| k.0.as_str()).collect(),
        }
    }

    fn request(&self, prompt: &str) -> Request {
        match &self.provider {
            Provider::Gemini { url, key } => {
                let mut config = json!({"responseModalities": ["IMAGE"]});
                if let Some(size) = self.size {
                    config["imageConfig"] = json!({"aspectRatio": aspect_ratio(size)});
                }
                let body =
                    json!({"contents": [{"role": "user", "parts": [{"text": prompt}]}], "generationConfig": config});
                Request {
                    url: url.clone(),
                    headers: gemini::headers(key.as_ref()),
                    body: body.to_string().into_bytes(),
                }
            }
            Provider::OpenAi { url, model, key } => {
                let mut body = json!({"model": model, "prompt": prompt, "n": 1, "size": openai_size(self.size)});
                // DALL·E models return URLs unless asked; GPT image models always return base64
                // and reject the parameter.
                if model.starts_with("dall-e") {
                    body["response_format"] = json!("b64_json");
                }
                let mut headers = vec![("content-type".to_string(), "application/json".to_string())];
                if let Some(k) = key {
                    headers.push(("authorization".into(), format!("Bearer {}", k.0)));
                }
                Request { url: url.clone(), headers, body: body.to_string().into_bytes() }
            }
        }
    }

    /// A refusal is a finished call (`Done(Err(reason))`): not retried, and reported as a
    /// blocked image rather than a failed render.
    fn judge(&self, resp: Response) -> Verdict<Result<Vec<u8>, String>> {
        if (200..300).contains(&resp.status) {
            let parsed = match &self.provider {
                Provider::Gemini { .. } => gemini_image(&resp.body),
                Provider::OpenAi { .. } => openai_image(&resp.body),
            };
            return match parsed {
                Ok(Some(b64)) => match base64::engine::general_purpose::STANDARD.decode(b64.trim()) {
                    Ok(bytes) => Verdict::Done(Ok(bytes)),
                    Err(e) => Verdict::Retry { reason: format!("malformed image data: {e}"), after: None },
                },
                Ok(None) => Verdict::Retry { reason: "malformed response: no image in it".into(), after: None },
                Err(Refused(msg)) => Verdict::Done(Err(msg)),
            };
        }
        let (message, permanent, after) = match &self.provider {
            Provider::Gemini { .. } => {
                let e = gemini::error(&resp.body);
                (e.message, e.permanent, e.retry_after)
            }
            Provider::OpenAi { .. } => {
                let v: Value = serde_json::from_slice(&resp.body).unwrap_or(Value::Null);
                let code = json_at::str_at(&v, &["error", "code"]).unwrap_or("");
                let msg = json_at::str_at(&v, &["error", "message"])
                    .map_or_else(|| snippet(&resp.body), |m| snippet(m.as_bytes()));
                if matches!(code, "content_policy_violation" | "moderation_blocked") {
                    return Verdict::Done(Err(format!(
                        "the prompt was blocked by the provider's safety system: {msg}"
                    )));
                }
                (if code.is_empty() { msg } else { format!("{msg} ({code})") }, code == "insufficient_quota", None)
            }
        };
        let reason = format!("HTTP {}: {message}", resp.status);
        if permanent || !http::is_transient(resp.status) {
            Verdict::Fail(reason)
        } else {
            Verdict::Retry { reason, after: resp.retry_after.or(after) }
        }
    }

    /// Re-encode as PNG at the requested size (providers return their own sizes and formats).
    fn to_png(&self, bytes: &[u8]) -> Result<Vec<u8>, String> {
        let img =
            image::load_from_memory(bytes).map_err(|e| format!("the provider returned an unreadable image: {e}"))?;
        let img = match self.size {
            Some((w, h)) if (img.width(), img.height()) != (w, h) => {
                img.resize_to_fill(w, h, image::imageops::FilterType::Lanczos3)
            }
            _ => img,
        };
        let mut out = Vec::new();
        img.write_to(&mut Cursor::new(&mut out), image::ImageFormat::Png)
            .map_err(|e| format!("cannot encode the image: {e}"))?;
        Ok(out)
    }
}

/// A response that was well-formed but refused or blocked.
struct Refused(String);

fn gemini_image(body: &[u8]) -> Result<Option<String>, Refused> {
    let Ok(v) = serde_json::from_slice::<Value>(body) else { return Ok(None) };
    if let Some(r) = json_at::str_at(&v, &["promptFeedback", "blockReason"]) {
        return Err(Refused(format!("the prompt was blocked by the provider ({r})")));
    }
    let Some(cand) = json_at::at(&v, &["candidates", "0"]) else { return Ok(None) };
    let parts = cand.pointer("/content/parts").and_then(Value::as_array).cloned().unwrap_or_default();
    if let Some(data) = parts.iter().find_map(|p| p.pointer("/inlineData/data").and_then(Value::as_str)) {
        return Ok(Some(data.to_string()));
    }
    let text: String = parts.iter().filter_map(|p| p.get("text").and_then(Value::as_str)).collect();
    match cand.get("finishReason").and_then(Value::as_str) {
        Some(
            r @ ("SAFETY"
            | "MODEL_ARMOR"
            | "IMAGE_SAFETY"
            | "PROHIBITED_CONTENT"
            | "IMAGE_PROHIBITED_CONTENT"
            | "BLOCKLIST"
            | "SPII"
            | "RECITATION"
            | "IMAGE_RECITATION"),
        ) => Err(Refused(format!("the image was blocked by the provider ({r})"))),
        _ if !text.trim().is_empty() => {
            Err(Refused(format!("the model returned no image, only text: {}", snippet(text.as_bytes()))))
        }
        Some(r @ ("NO_IMAGE" | "IMAGE_OTHER" | "OTHER")) => Err(Refused(format!("the model returned no image ({r})"))),
        _ => Ok(None),
    }
}

fn openai_image(body: &[u8]) -> Result<Option<String>, Refused> {
    let Ok(v) = serde_json::from_slice::<Value>(body) else { return Ok(None) };
    Ok(json_at::str_at(&v, &["data", "0", "b64_json"]).map(str::to_string))
}

impl Renderer for ImageGen {
    fn id(&self) -> String {
        self.id.clone()
    }

    fn render<'a>(&'a self, _scene: &'a Scene, prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>> {
        Box::pin(async move {
            if prompt.trim().is_empty() {
                return Err(RenderError::new("cannot generate an image: the scene's image prompt is empty"));
            }
            let k = parts_hex([&b"imagegen-v1"[..], self.id.as_bytes(), prompt.as_bytes()]);
            if let Some(png) = self.cache.as_ref().and_then(|c| c.get(&k)) {
                return Ok(Rendered { png, cached: true, visibility: None });
            }
            let called = self.transport.call(|| Ok(self.request(prompt)), |r| self.judge(r)).await;
            let secrets = self.secrets();
            let fail = |m: String| {
                RenderError::new(redact(format!("image generation with `{}` failed: {m}", self.id), &secrets))
            };
            let bytes = match called.result {
                Ok(Ok(bytes)) => bytes,
                Ok(Err(refused)) => {
                    return Err(RenderError::blocked(redact(format!("`{}` refused: {refused}", self.id), &secrets)));
                }
                Err(e) => return Err(fail(e)),
            };
            let png = self.to_png(&bytes).map_err(fail)?;
            if let Some(c) = &self.cache {
                // A cache that cannot be written only costs a regeneration later.
                let _ = c.put(&k, &png);
            }
            Ok(Rendered { png, cached: false, visibility: None })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aspect_ratios_and_sizes() {
        assert_eq!(aspect_ratio((1600, 900)), "16:9");
        assert_eq!(aspect_ratio((800, 600)), "4:3");
        assert_eq!(aspect_ratio((512, 512)), "1:1");
        assert_eq!(openai_size(Some((1600, 900))), "1536x1024");
        assert_eq!(openai_size(Some((600, 1000))), "1024x1536");
        assert_eq!(openai_size(None), "1024x1024");
    }

    #[test]
    fn gemini_blocks_and_text_only_replies_are_refusals() {
        let blocked = br#"{"promptFeedback":{"blockReason":"SAFETY"}}"#;
        assert!(matches!(gemini_image(blocked), Err(Refused(m)) if m.contains("SAFETY")));
        let text =
            br#"{"candidates":[{"content":{"parts":[{"text":"I can't create that image."}]},"finishReason":"STOP"}]}"#;
        assert!(matches!(gemini_image(text), Err(Refused(m)) if m.contains("only text")));
        let img = br#"{"candidates":[{"content":{"parts":[{"text":"Here"},{"inlineData":{"mimeType":"image/png","data":"AAAA"}}]},"finishReason":"STOP"}]}"#;
        assert_eq!(gemini_image(img).ok().flatten().as_deref(), Some("AAAA"));
        assert!(matches!(gemini_image(b"{"), Ok(None)));
    }

    #[test]
    fn bad_specs() {
        let o = RendererOptions::default();
        assert!(build("imagegen:gemini", &o).err().unwrap().contains("expected `imagegen:gemini:MODEL`"));
        assert!(
            build("imagegen:midjourney:v6", &o)
                .err()
                .unwrap()
                .contains("unknown image-generation provider `midjourney`")
        );
    }
}
