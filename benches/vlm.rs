//! Model-client benchmarks.
//!
//! 1. Throughput: 1000 inferences through the `Model` trait against a local OpenAI-compatible
//!    mock that takes 1 s per call, at concurrency 32. The physical limit is
//!    ceil(1000 / 32) × 1 s = 32 s; the client's overhead is what is above it. Run once (a
//!    30-second iteration is not a criterion sample), printed as a table line.
//! 2. Answer parsing (criterion): real-looking replies through `vlm::parse::parse`.
//!
//! `cargo bench --bench vlm` (add `-- --quick` for a short parser run).

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::Criterion;
use revelio::outcome::Answer;
use revelio::vlm::registry::{ModelOptions, build_api_model};
use revelio::vlm::{Query, parse, prompt};
use serde_json::json;
use wiremock::matchers::method;
use wiremock::{Mock, MockServer, ResponseTemplate};

const CALLS: usize = 1000;
const CONCURRENCY: usize = 32;
const LATENCY: Duration = Duration::from_secs(1);

fn throughput() {
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
    rt.block_on(async {
        let server = MockServer::start().await;
        let body = json!({"choices": [{"index": 0, "message": {"role": "assistant", "content": "The road is clear.\nAnswer: C"}, "finish_reason": "stop"}],
                          "usage": {"prompt_tokens": 1200, "completion_tokens": 12}});
        Mock::given(method("POST")).respond_with(ResponseTemplate::new(200).set_body_json(body).set_delay(LATENCY)).mount(&server).await;
        let dir = tempfile::tempdir().unwrap();
        let cfg = dir.path().join("models.toml");
        std::fs::write(&cfg, format!("[default]\nconcurrency = {CONCURRENCY}\ntimeout_s = 30\n")).unwrap();
        let opts = ModelOptions { base_url: Some(server.uri()), config: Some(cfg), no_cache: true, ..Default::default() };
        let model = build_api_model("openai:bench", &opts).unwrap();
        // A realistic image: a 640×360 PNG of noise-free gradients (~100 KB base64-encoded).
        let img = image::RgbImage::from_fn(640, 360, |x, y| image::Rgb([(x % 256) as u8, (y % 256) as u8, ((x + y) % 256) as u8]));
        let mut png = Vec::new();
        image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
        let png = Arc::new(png);
        let options = vec!["Stop".to_string(), "Slow down".to_string(), "Continue".to_string()];
        let start = Instant::now();
        let mut set = tokio::task::JoinSet::new();
        for i in 0..CALLS {
            let (m, png, options) = (model.clone(), png.clone(), options.clone());
            set.spawn(async move {
                let q = Query {
                    image: Some(png),
                    image_hash: format!("{i:064}"),
                    prompt: prompt::build(&format!("Scene {i}: what should the ego vehicle do?"), &options),
                    options,
                    truth: None,
                };
                m.ask(&q).await
            });
        }
        let mut ok = 0;
        while let Some(r) = set.join_next().await {
            ok += usize::from(r.unwrap().answer == Answer::Option(2));
        }
        let wall = start.elapsed().as_secs_f64();
        let limit = CALLS.div_ceil(CONCURRENCY) as f64 * LATENCY.as_secs_f64();
        println!(
            "vlm/throughput: {CALLS} calls, {ok} answered, concurrency {CONCURRENCY}, {:.0} ms mock latency: {wall:.2} s wall (physical limit {limit:.0} s, overhead {:+.1}%)",
            LATENCY.as_secs_f64() * 1000.0,
            (wall / limit - 1.0) * 100.0
        );
    });
}

fn parsing(c: &mut Criterion) {
    let options = vec!["Stop".to_string(), "Slow down".to_string(), "Continue at the same speed".to_string()];
    let replies = [
        "**Analysis:**\n\n* Debris lies in the ego lane about 15 m ahead.\n* Fog reduces visibility.\n\nThe vehicle must stop.\n\nAnswer: A",
        "<think>\nThe cone is on the shoulder. Slow seems right.\n</think>\n\nThe cone is not in the lane.\n\nAnswer: B",
        "The road ahead is clear.\n<|begin_of_box|>C<|end_of_box|>",
        "Given the fog, the answer is B because visibility is poor and a cyclist may be ahead.",
        "I see a road with a truck parked on the right and a pedestrian on the sidewalk.",
    ];
    c.bench_function("vlm/parse 5 replies", |b| {
        b.iter(|| {
            replies
                .iter()
                .map(|r| parse::parse(black_box(r), &options))
                .filter(|a| matches!(a, Answer::Option(_)))
                .count()
        })
    });
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    parsing(&mut c);
    c.final_summary();
    throughput();
}
