//! The headless wgpu device: adapter choice, pipelines, and one frame → RGBA8 pixels.
//!
//! The device is created once per process and shared: a search renders thousands of images, and
//! creating a device costs far more than a frame. Frames are serialised by one mutex that owns
//! the per-size targets and the growable vertex buffer (the GPU queue is a single queue anyway).

use std::sync::Mutex;

use wgpu::util::DeviceExt;

use super::atmosphere::Frame;
use super::mesh::{Mesh, Vertex};

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The entity-id target: r = 1 + entity index (exact in f16 up to 2048), a = claim. A float
/// format so that blended passes can keep or take the id behind them ([`ID_UNDER`]).
const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// How blended (translucent) fragments write the id target: `src · (1 − dst.a) + dst`. Where an
/// entity already claims the pixel (a = 1) it keeps it — an entity seen through glass or smoke
/// is seen — and elsewhere (a = 0: sky, scenery) a claiming fragment takes it and a fragment
/// that does not claim (scenery glass, a = 0) leaves it as it is.
const ID_UNDER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};
/// Bytes per pixel of `ID_FORMAT`.
const ID_BYTES: u32 = 8;
/// Multisampling for clean edges on GPUs; falls back to 1 where the adapter cannot. CPU drivers
/// get 1: there 4× multisampling costs about 2.5× the frame time (measured with llvmpipe and
/// lavapipe), and the speed target is set for them. `REVELIO_MSAA=1|4` overrides the choice.
const MSAA: u32 = 4;
/// Packages that provide the Mesa CPU drivers on Debian/Ubuntu, named in the error.
pub const DRIVER_PACKAGES: &str =
    "mesa-vulkan-drivers (Vulkan, lavapipe) or libegl1 libegl-mesa0 libgl1-mesa-dri (OpenGL, llvmpipe)";

/// One frame read back: the colour image and, per pixel, which placed entity is seen there.
pub struct Drawn {
    /// sRGB RGBA8 rows, tightly packed.
    pub pixels: Vec<u8>,
    /// Per pixel: 0 where no placed entity is seen (stage, extras, sky), else 1 + its index in
    /// `Scene.entities`; with multisampling, an edge pixel may hold a blend of two ids.
    pub ids: Vec<f32>,
}

/// What `revelio render --info` prints.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    /// Multisampling used for every frame (1: none).
    pub samples: u32,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, {})", self.name, self.backend, self.device_type)?;
        if !self.driver.is_empty() {
            write!(f, ", driver {}", self.driver)?;
        }
        write!(f, ", {}× MSAA", self.samples)
    }
}

pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    summary: AdapterSummary,
    layout: wgpu::BindGroupLayout,
    sky: wgpu::RenderPipeline,
    opaque: wgpu::RenderPipeline,
    blended: wgpu::RenderPipeline,
    rain: wgpu::RenderPipeline,
    state: Mutex<State>,
}

/// Per-size render targets and the geometry buffers, reused across frames.
#[derive(Default)]
struct State {
    targets: Option<Targets>,
    vertices: Option<(wgpu::Buffer, u64)>,
    indices: Option<(wgpu::Buffer, u64)>,
}

impl Gpu {
    /// Make `slot` hold a buffer of at least `need` bytes (grown to a power of two).
    fn ensure(&self, slot: &mut Option<(wgpu::Buffer, u64)>, need: u64, usage: wgpu::BufferUsages) {
        let need = need.max(4);
        if slot.as_ref().is_none_or(|(_, cap)| *cap < need) {
            let cap = need.next_power_of_two();
            let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: cap,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            *slot = Some((buf, cap));
        }
    }
}

struct Targets {
    size: (u32, u32),
    msaa: Option<wgpu::TextureView>,
    resolve: wgpu::Texture,
    resolve_view: wgpu::TextureView,
    id_msaa: Option<wgpu::TextureView>,
    id_resolve: wgpu::Texture,
    id_resolve_view: wgpu::TextureView,
    depth: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
    id_readback: wgpu::Buffer,
    id_padded_row: u32,
    uniforms: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// Rank adapters: a real GPU first (Vulkan over GL); among CPU drivers llvmpipe (GL) over
/// lavapipe (Vulkan), which drew this renderer's frames about 10 % slower (docs/render.md).
fn adapter_rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let cpu = info.device_type == wgpu::DeviceType::Cpu;
    let backend = match info.backend {
        wgpu::Backend::Vulkan => u8::from(cpu),
        wgpu::Backend::Gl => u8::from(!cpu),
        _ => 2,
    };
    (kind, backend)
}

impl Gpu {
    /// Pick the best adapter (`WGPU_BACKEND=vulkan|gl` restricts the choice) and build the
    /// pipelines.
    pub fn new() -> Result<Gpu, String> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::GL;
        let instance = wgpu::Instance::new(desc.with_env());
        let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        adapters.sort_by_key(|a| adapter_rank(&a.get_info()));
        let adapter = adapters.into_iter().next().ok_or_else(|| {
            format!(
                "no graphics adapter found for the builtin renderer: install {DRIVER_PACKAGES}, or use a GPU driver"
            )
        })?;
        let info = adapter.get_info();
        let flags = adapter.get_texture_format_features(COLOR_FORMAT).flags;
        let wanted = match std::env::var("REVELIO_MSAA") {
            Ok(v) => match v.trim() {
                "1" => 1,
                "4" => 4,
                other => return Err(format!("REVELIO_MSAA must be 1 or 4, not `{other}`")),
            },
            Err(_) if info.device_type == wgpu::DeviceType::Cpu => 1,
            Err(_) => MSAA,
        };
        let samples = if wanted > 1 && flags.sample_count_supported(wanted) { wanted } else { 1 };
        let summary = AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend).to_lowercase(),
            device_type: format!("{:?}", info.device_type),
            driver: [info.driver.as_str(), info.driver_info.as_str()]
                .iter()
                .filter(|s| !s.is_empty())
                .copied()
                .collect::<Vec<_>>()
                .join(" "),
            samples,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("revelio"),
            required_limits: wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| format!("cannot open the graphics device `{}`: {e}", summary.name))?;
        Ok(Gpu::with_device(device, queue, summary))
    }

    pub fn summary(&self) -> &AdapterSummary {
        &self.summary
    }

    fn with_device(device: wgpu::Device, queue: wgpu::Queue, summary: AdapterSummary) -> Gpu {
        let samples = summary.samples;
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("revelio"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let attrs =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Float32, 4 => Float32];
        let vbuf = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &attrs,
        })];
        // `vertex_buffers`: whether the pipeline draws the mesh (else its vertices come from
        // the vertex index); `depth`: compare and write. Nothing is culled: closed parts lose
        // their back faces in `mesh`, and planes are seen from both sides.
        // `id`: whether the pass writes the id target (the sky and rain leave it as it is).
        let pipeline =
            |vs: &str, fs: &str, vertex_buffers: bool, depth: (wgpu::CompareFunction, bool), blend: bool, id: bool| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(fs),
                    layout: Some(&pl),
                    vertex: wgpu::VertexState {
                        module: &shader,
                        entry_point: Some(vs),
                        compilation_options: Default::default(),
                        buffers: if vertex_buffers { &vbuf } else { &[] },
                    },
                    primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                    depth_stencil: Some(wgpu::DepthStencilState {
                        format: DEPTH_FORMAT,
                        depth_write_enabled: Some(depth.1),
                        depth_compare: Some(depth.0),
                        stencil: Default::default(),
                        bias: Default::default(),
                    }),
                    multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                    fragment: Some(wgpu::FragmentState {
                        module: &shader,
                        entry_point: Some(fs),
                        compilation_options: Default::default(),
                        targets: &[
                            Some(wgpu::ColorTargetState {
                                format: COLOR_FORMAT,
                                blend: blend.then_some(wgpu::BlendState::ALPHA_BLENDING),
                                write_mask: wgpu::ColorWrites::ALL,
                            }),
                            Some(wgpu::ColorTargetState {
                                format: ID_FORMAT,
                                blend: blend.then_some(ID_UNDER),
                                write_mask: if id { wgpu::ColorWrites::ALL } else { wgpu::ColorWrites::empty() },
                            }),
                        ],
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            };
        use wgpu::CompareFunction::{Always, GreaterEqual};
        let opaque = pipeline("vs_main", "fs_main", true, (GreaterEqual, true), false, true);
        // The sky lies at depth 0 (infinitely far, the cleared value), drawn after the solids:
        // the depth test then shades only the pixels no solid covers.
        let sky = pipeline("vs_fullscreen", "fs_sky", false, (GreaterEqual, false), false, false);
        let blended = pipeline("vs_main", "fs_main", true, (GreaterEqual, false), true, true);
        let rain = pipeline("vs_rain", "fs_rain", false, (Always, false), true, false);
        Gpu { device, queue, summary, layout, sky, opaque, blended, rain, state: Mutex::new(State::default()) }
    }

    /// Render one frame with `rain_streaks` rain streaks and read back its colour and its
    /// entity ids, drawn in the same passes.
    pub fn draw(&self, mesh: &Mesh, frame: &Frame, rain_streaks: u32) -> Result<Drawn, String> {
        let (w, h) = (frame.viewport[0] as u32, frame.viewport[1] as u32);
        // A poisoned lock only means another frame panicked mid-way; the state is rebuilt below.
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if state.targets.as_ref().is_none_or(|t| t.size != (w, h)) {
            state.targets = Some(self.targets(w, h));
        }
        let vbytes: &[u8] = bytemuck::cast_slice(&mesh.vertices);
        let ibytes: &[u8] = bytemuck::cast_slice(&mesh.indices);
        self.ensure(&mut state.vertices, vbytes.len() as u64, wgpu::BufferUsages::VERTEX);
        self.ensure(&mut state.indices, ibytes.len() as u64, wgpu::BufferUsages::INDEX);
        let State { targets: Some(t), vertices: Some((vbuf, _)), indices: Some((ibuf, _)) } = &*state else {
            unreachable!("targets and geometry buffers are created above");
        };
        if !ibytes.is_empty() {
            self.queue.write_buffer(vbuf, 0, vbytes);
            self.queue.write_buffer(ibuf, 0, ibytes);
        }
        self.queue.write_buffer(&t.uniforms, 0, bytemuck::bytes_of(frame));

        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let (view, resolve_target) = match &t.msaa {
                Some(m) => (m, Some(&t.resolve_view)),
                None => (&t.resolve_view, None),
            };
            let (id_view, id_resolve_target) = match &t.id_msaa {
                Some(m) => (m, Some(&t.id_resolve_view)),
                None => (&t.id_resolve_view, None),
            };
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[
                    Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    }),
                    Some(wgpu::RenderPassColorAttachment {
                        view: id_view,
                        depth_slice: None,
                        resolve_target: id_resolve_target,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    }),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &t.depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &t.bind_group, &[]);
            let n = mesh.indices.len() as u32;
            if n > 0 {
                pass.set_vertex_buffer(0, vbuf.slice(..));
                pass.set_index_buffer(ibuf.slice(..), wgpu::IndexFormat::Uint32);
                pass.set_pipeline(&self.opaque);
                pass.draw_indexed(0..mesh.opaque_len, 0, 0..1);
            }
            pass.set_pipeline(&self.sky);
            pass.draw(0..3, 0..1);
            if mesh.opaque_len < n {
                pass.set_pipeline(&self.blended);
                pass.draw_indexed(mesh.opaque_len..n, 0, 0..1);
            }
            if rain_streaks > 0 {
                // Six vertices (two triangles) per streak, placed by the vertex shader.
                pass.set_pipeline(&self.rain);
                pass.draw(0..rain_streaks * 6, 0..1);
            }
        }
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &t.resolve,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &t.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(t.padded_row),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &t.id_resolve,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &t.id_readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(t.id_padded_row),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        let index = self.queue.submit([enc.finish()]);
        let slice = t.readback.slice(..);
        let id_slice = t.id_readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        for s in [&slice, &id_slice] {
            let tx = tx.clone();
            s.map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        }
        drop(tx);
        self.device
            .poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })
            .map_err(|e| format!("the graphics device failed while rendering: {e}"))?;
        for _ in 0..2 {
            rx.recv()
                .map_err(|_| "the graphics device dropped a readback".to_string())?
                .map_err(|e| format!("cannot read the rendered image back: {e}"))?;
        }
        let mut out = Vec::with_capacity((w * h * 4) as usize);
        {
            let data = slice.get_mapped_range().map_err(|e| format!("cannot read the rendered image back: {e}"))?;
            if t.padded_row == w * 4 {
                out.extend_from_slice(&data[..(w * h * 4) as usize]);
            } else {
                for row in data.chunks(t.padded_row as usize).take(h as usize) {
                    out.extend_from_slice(&row[..(w * 4) as usize]);
                }
            }
        }
        t.readback.unmap();
        let mut ids = Vec::with_capacity((w * h) as usize);
        {
            let data = id_slice.get_mapped_range().map_err(|e| format!("cannot read the rendered ids back: {e}"))?;
            for row in data.chunks(t.id_padded_row as usize).take(h as usize) {
                // The red channel of each RGBA16F texel.
                ids.extend(
                    row[..(w * ID_BYTES) as usize]
                        .chunks_exact(ID_BYTES as usize)
                        .map(|px| f16_to_f32(u16::from_le_bytes([px[0], px[1]]))),
                );
            }
        }
        t.id_readback.unmap();
        Ok(Drawn { pixels: out, ids })
    }

    fn targets(&self, w: u32, h: u32) -> Targets {
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let tex = |label, format, samples, usage| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let samples = self.summary.samples;
        let msaa = (samples > 1).then(|| tex("msaa", COLOR_FORMAT, samples, attach).create_view(&Default::default()));
        let resolve = tex("resolve", COLOR_FORMAT, 1, attach | wgpu::TextureUsages::COPY_SRC);
        let id_msaa =
            (samples > 1).then(|| tex("id msaa", ID_FORMAT, samples, attach).create_view(&Default::default()));
        let id_resolve = tex("id resolve", ID_FORMAT, 1, attach | wgpu::TextureUsages::COPY_SRC);
        let depth = tex("depth", DEPTH_FORMAT, samples, attach).create_view(&Default::default());
        let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let padded_row = (w * 4).div_ceil(align) * align;
        let id_padded_row = (w * ID_BYTES).div_ceil(align) * align;
        let buffer = |label, row: u32| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: row as u64 * h as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let readback = buffer("readback", padded_row);
        let id_readback = buffer("id readback", id_padded_row);
        let uniforms = self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("frame"),
            contents: bytemuck::bytes_of(&Frame::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() }],
        });
        Targets {
            size: (w, h),
            msaa,
            resolve_view: resolve.create_view(&Default::default()),
            resolve,
            id_msaa,
            id_resolve_view: id_resolve.create_view(&Default::default()),
            id_resolve,
            depth,
            readback,
            padded_row,
            id_readback,
            id_padded_row,
            uniforms,
            bind_group,
        }
    }
}

use bytemuck::Zeroable;

/// IEEE half → single precision (the id target is read back as f16).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let frac = f32::from(h & 0x3ff);
    sign * match exp {
        0 => frac * 2f32.powi(-24),
        31 if frac == 0.0 => f32::INFINITY,
        31 => f32::NAN,
        e => (1.0 + frac / 1024.0) * 2f32.powi(e - 15),
    }
}

#[cfg(test)]
mod tests {
    use super::f16_to_f32;

    #[test]
    fn half_floats_decode_to_the_ids_they_hold() {
        assert_eq!(f16_to_f32(0x0000), 0.0);
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0x4000), 2.0);
        assert_eq!(f16_to_f32(0x4a40), 12.5);
        assert_eq!(f16_to_f32(0x6800), 2048.0);
        assert_eq!(f16_to_f32(0x3800), 0.5);
        assert_eq!(f16_to_f32(0xc000), -2.0);
    }
}
