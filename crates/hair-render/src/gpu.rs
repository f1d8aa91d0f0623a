//! The wgpu path of Ward, Galoppo & Lin's renderer (§5): one pass writes the 16 opacity maps into
//! four `Rgba16Float` targets with additive blending plus the body's depth map; a second pass
//! shades hair and body under those maps. Headless rendering reads the colour target back.

use crate::RenderError;
use crate::frame::{Globals, globals};
use crate::geometry::{BodyVertex, PreparedScene, RibbonVertex, prepare};
use crate::osm::{OSM_MAPS, OpacityMaps, f16_to_f32};
use crate::scene::{RenderScene, RenderSettings};
use image::RgbaImage;
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// The WGSL shared by both passes.
pub const COMMON_WGSL: &str = include_str!("shaders/common.wgsl");
/// The opacity-map pass.
pub const OSM_PASS_WGSL: &str = include_str!("shaders/osm_pass.wgsl");
/// The shading pass.
pub const SHADE_PASS_WGSL: &str = include_str!("shaders/shade_pass.wgsl");

/// The complete source of the opacity-map pass module.
pub fn osm_shader_source() -> String {
    format!("{COMMON_WGSL}\n{OSM_PASS_WGSL}")
}

/// The complete source of the shading pass module.
pub fn shade_shader_source() -> String {
    format!("{COMMON_WGSL}\n{SHADE_PASS_WGSL}")
}

const OSM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Renders scenes with wgpu, headless or into a caller's texture view (a window surface).
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    color_format: wgpu::TextureFormat,
    uniform_layout: wgpu::BindGroupLayout,
    layout: wgpu::BindGroupLayout,
    osm_hair: wgpu::RenderPipeline,
    osm_body: wgpu::RenderPipeline,
    shade_hair: wgpu::RenderPipeline,
    shade_body: wgpu::RenderPipeline,
}

impl std::fmt::Debug for GpuRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuRenderer")
            .field("adapter", &self.info.name)
            .field("backend", &self.info.backend)
            .finish_non_exhaustive()
    }
}

fn ribbon_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 9] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32, 2 => Float32x3, 3 => Float32, 4 => Float32x3,
        5 => Float32, 6 => Float32x3, 7 => Float32, 8 => Float32x4
    ];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<RibbonVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

fn body_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRS: [wgpu::VertexAttribute; 2] = [
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: 0,
            shader_location: 0,
        },
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: 16,
            shader_location: 1,
        },
    ];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<BodyVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRS,
    }
}

struct PipelineSpec<'a> {
    module: &'a wgpu::ShaderModule,
    vertex: wgpu::VertexBufferLayout<'static>,
    targets: &'a [Option<wgpu::ColorTargetState>],
    depth_write: bool,
    depth_compare: wgpu::CompareFunction,
}

fn pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    label: &str,
    spec: PipelineSpec<'_>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module: spec.module,
            entry_point: Some(if label.ends_with("hair") {
                "vs_hair"
            } else {
                "vs_body"
            }),
            compilation_options: Default::default(),
            buffers: &[Some(spec.vertex)],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(spec.depth_write),
            depth_compare: Some(spec.depth_compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: spec.module,
            entry_point: Some(if label.ends_with("hair") {
                "fs_hair"
            } else {
                "fs_body"
            }),
            compilation_options: Default::default(),
            targets: spec.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// GPU resources of one frame.
struct Frame {
    osm: [wgpu::Texture; 4],
    osm_depth: wgpu::Texture,
    color: wgpu::Texture,
    depth: wgpu::Texture,
    uniform_group: wgpu::BindGroup,
    bind_group: wgpu::BindGroup,
}

fn texture(
    device: &wgpu::Device,
    label: &str,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

fn wait(device: &wgpu::Device) -> Result<(), RenderError> {
    loop {
        match device.poll(wgpu::PollType::wait_indefinitely()) {
            Ok(_) => return Ok(()),
            Err(wgpu::PollError::Timeout) => continue,
            Err(e) => return Err(RenderError::Device(e.to_string())),
        }
    }
}

impl GpuRenderer {
    /// A headless renderer on the first adapter of the backends named by `WGPU_BACKEND`
    /// (all backends when unset); images are `Rgba8Unorm`.
    pub fn new() -> Result<Self, RenderError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        }))
        .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("hair-render"),
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(e.to_string()))?;
        Ok(Self::with_device(
            device,
            queue,
            info,
            wgpu::TextureFormat::Rgba8Unorm,
        ))
    }

    /// A renderer on a caller's device drawing into `color_format` (a window surface's format).
    pub fn with_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        info: wgpu::AdapterInfo,
        color_format: wgpu::TextureFormat,
    ) -> Self {
        device.on_uncaptured_error(Arc::new(|e| eprintln!("hair-render: wgpu error: {e}")));
        let tex = |binding, sample_type| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let uniform_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hair-render globals"),
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
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hair-render shadow maps"),
            entries: &[
                tex(1, float),
                tex(2, float),
                tex(3, float),
                tex(4, float),
                tex(5, wgpu::TextureSampleType::Depth),
                wgpu::BindGroupLayoutEntry {
                    binding: 6,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
            ],
        });
        let osm_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hair-render osm"),
            bind_group_layouts: &[Some(&uniform_layout)],
            immediate_size: 0,
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hair-render shade"),
            bind_group_layouts: &[Some(&uniform_layout), Some(&layout)],
            immediate_size: 0,
        });
        let osm_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("osm pass"),
            source: wgpu::ShaderSource::Wgsl(osm_shader_source().into()),
        });
        let shade_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shade pass"),
            source: wgpu::ShaderSource::Wgsl(shade_shader_source().into()),
        });
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let osm_target = |write_mask| {
            Some(wgpu::ColorTargetState {
                format: OSM_FORMAT,
                blend: Some(wgpu::BlendState {
                    color: add,
                    alpha: add,
                }),
                write_mask,
            })
        };
        let all = wgpu::ColorWrites::ALL;
        let none = wgpu::ColorWrites::empty();
        let hair_targets = [
            osm_target(all),
            osm_target(all),
            osm_target(all),
            osm_target(all),
        ];
        let body_targets = [
            osm_target(none),
            osm_target(none),
            osm_target(none),
            osm_target(none),
        ];
        let color_target = [Some(wgpu::ColorTargetState {
            format: color_format,
            blend: None,
            write_mask: all,
        })];
        let osm_hair = pipeline(
            &device,
            &osm_pl,
            "osm hair",
            PipelineSpec {
                module: &osm_module,
                vertex: ribbon_layout(),
                targets: &hair_targets,
                depth_write: false,
                depth_compare: wgpu::CompareFunction::Always,
            },
        );
        let osm_body = pipeline(
            &device,
            &osm_pl,
            "osm body",
            PipelineSpec {
                module: &osm_module,
                vertex: body_layout(),
                targets: &body_targets,
                depth_write: true,
                depth_compare: wgpu::CompareFunction::Less,
            },
        );
        let shade_hair = pipeline(
            &device,
            &pl,
            "shade hair",
            PipelineSpec {
                module: &shade_module,
                vertex: ribbon_layout(),
                targets: &color_target,
                depth_write: true,
                depth_compare: wgpu::CompareFunction::Less,
            },
        );
        let shade_body = pipeline(
            &device,
            &pl,
            "shade body",
            PipelineSpec {
                module: &shade_module,
                vertex: body_layout(),
                targets: &color_target,
                depth_write: true,
                depth_compare: wgpu::CompareFunction::Less,
            },
        );
        Self {
            device,
            queue,
            info,
            color_format,
            uniform_layout,
            layout,
            osm_hair,
            osm_body,
            shade_hair,
            shade_body,
        }
    }

    /// The adapter in use.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// A short description such as `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    fn check_size(&self, w: u32, h: u32, what: &str) -> Result<(), RenderError> {
        let max = self.device.limits().max_texture_dimension_2d;
        if w == 0 || h == 0 {
            return Err(RenderError::InvalidSize {
                width: w,
                height: h,
                reason: format!("{what}: a side is zero"),
            });
        }
        if w > max || h > max {
            return Err(RenderError::InvalidSize {
                width: w,
                height: h,
                reason: format!("{what}: beyond the adapter's limit of {max} texels"),
            });
        }
        Ok(())
    }

    fn frame(&self, g: &Globals, w: u32, h: u32) -> (Frame, wgpu::Buffer) {
        let d = &self.device;
        let size = g.osm[3] as u32;
        let osm_usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let osm = [0, 1, 2, 3]
            .map(|i| texture(d, &format!("osm {i}"), size, size, OSM_FORMAT, osm_usage));
        let osm_depth = texture(d, "osm depth", size, size, DEPTH_FORMAT, osm_usage);
        let color = texture(
            d,
            "color",
            w,
            h,
            self.color_format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture(
            d,
            "depth",
            w,
            h,
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let uniforms = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("globals"),
            contents: bytemuck::bytes_of(g),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let views: Vec<wgpu::TextureView> = osm
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let depth_view = osm_depth.create_view(&wgpu::TextureViewDescriptor {
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("body depth"),
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let uniform_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("globals"),
            layout: &self.uniform_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow maps"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&views[0]),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&views[1]),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&views[2]),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&views[3]),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&depth_view),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
            ],
        });
        (
            Frame {
                osm,
                osm_depth,
                color,
                depth,
                uniform_group,
                bind_group,
            },
            uniforms,
        )
    }

    /// Encodes both passes; the shading pass draws into `target`.
    fn encode(
        &self,
        prepared: &PreparedScene,
        frame: &Frame,
        target: &wgpu::TextureView,
        shadows: bool,
        background: [f32; 3],
    ) -> wgpu::CommandEncoder {
        let d = &self.device;
        let buf = |label, data: &[u8], usage| {
            (!data.is_empty()).then(|| {
                d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: data,
                    usage,
                })
            })
        };
        let vb = wgpu::BufferUsages::VERTEX;
        let ib = wgpu::BufferUsages::INDEX;
        let hair_vb = buf(
            "hair vertices",
            bytemuck::cast_slice(&prepared.hair_vertices),
            vb,
        );
        let hair_ib = buf(
            "hair indices",
            bytemuck::cast_slice(&prepared.hair_indices),
            ib,
        );
        let body_vb = buf(
            "body vertices",
            bytemuck::cast_slice(&prepared.body_vertices),
            vb,
        );
        let body_ib = buf(
            "body indices",
            bytemuck::cast_slice(&prepared.body_indices),
            ib,
        );
        let hair = hair_vb.as_ref().zip(hair_ib.as_ref());
        let body = body_vb.as_ref().zip(body_ib.as_ref());
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("hair-render frame"),
        });
        if shadows {
            let views: Vec<wgpu::TextureView> = frame
                .osm
                .iter()
                .map(|t| t.create_view(&Default::default()))
                .collect();
            let attachments: Vec<Option<wgpu::RenderPassColorAttachment<'_>>> = views
                .iter()
                .map(|v| {
                    Some(wgpu::RenderPassColorAttachment {
                        view: v,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    })
                })
                .collect();
            let depth_view = frame.osm_depth.create_view(&Default::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("opacity shadow maps"),
                color_attachments: &attachments,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &frame.uniform_group, &[]);
            if let Some((v, i)) = body {
                pass.set_pipeline(&self.osm_body);
                pass.set_vertex_buffer(0, v.slice(..));
                pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..prepared.body_indices.len() as u32, 0, 0..1);
            }
            if let Some((v, i)) = hair {
                pass.set_pipeline(&self.osm_hair);
                pass.set_vertex_buffer(0, v.slice(..));
                pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..prepared.hair_indices.len() as u32, 0, 0..1);
            }
        }
        {
            let depth_view = frame.depth.create_view(&Default::default());
            let [r, g, b] = background.map(|c| f64::from(c.clamp(0.0, 1.0)));
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shading"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &frame.uniform_group, &[]);
            pass.set_bind_group(1, &frame.bind_group, &[]);
            if let Some((v, i)) = body {
                pass.set_pipeline(&self.shade_body);
                pass.set_vertex_buffer(0, v.slice(..));
                pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..prepared.body_indices.len() as u32, 0, 0..1);
            }
            if let Some((v, i)) = hair {
                pass.set_pipeline(&self.shade_hair);
                pass.set_vertex_buffer(0, v.slice(..));
                pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..prepared.hair_indices.len() as u32, 0, 0..1);
            }
        }
        enc
    }

    fn scoped<T>(&self, f: impl FnOnce() -> Result<T, RenderError>) -> Result<T, RenderError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        if let Some(e) = v.or(o) {
            return Err(RenderError::Device(e.to_string()));
        }
        out
    }

    fn setup(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
    ) -> Result<(PreparedScene, Globals, crate::osm::LightFrame), RenderError> {
        settings.validate()?;
        self.check_size(settings.width, settings.height, "image")?;
        self.check_size(
            settings.shadow.map_size,
            settings.shadow.map_size,
            "shadow map",
        )?;
        let prepared = prepare(scene, settings.subdivisions)?;
        let max_buf = self.device.limits().max_buffer_size;
        let bytes = (prepared.hair_vertices.len() * std::mem::size_of::<RibbonVertex>()) as u64;
        if bytes > max_buf {
            return Err(crate::scene::invalid(
                "scene",
                format!(
                    "{bytes} bytes of hair vertices exceed the adapter's buffer limit {max_buf}"
                ),
            ));
        }
        let (g, lf) = globals(scene, &prepared, settings);
        Ok((prepared, g, lf))
    }

    /// Renders into a caller's texture view of this renderer's colour format (for example a
    /// window surface's current texture), `settings.width` x `settings.height`.
    pub fn render_to_view(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        target: &wgpu::TextureView,
    ) -> Result<(), RenderError> {
        let (prepared, g, _) = self.setup(scene, settings)?;
        self.scoped(|| {
            let (frame, _u) = self.frame(&g, settings.width, settings.height);
            let enc = self.encode(
                &prepared,
                &frame,
                target,
                settings.shadows,
                scene.background,
            );
            self.queue.submit([enc.finish()]);
            Ok(())
        })
    }

    /// Renders a scene and reads the image back.
    pub fn render_to_image(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
    ) -> Result<RgbaImage, RenderError> {
        if !matches!(
            self.color_format,
            wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb
        ) {
            return Err(crate::scene::invalid(
                "render_to_image",
                "needs a renderer made for Rgba8Unorm",
            ));
        }
        let (prepared, g, _) = self.setup(scene, settings)?;
        let (w, h) = (settings.width, settings.height);
        let bytes = self.scoped(|| {
            let (frame, _u) = self.frame(&g, w, h);
            let view = frame.color.create_view(&Default::default());
            let mut enc = self.encode(&prepared, &frame, &view, settings.shadows, scene.background);
            let read = self.copy_out(&mut enc, &frame.color, w, h, 4, wgpu::TextureAspect::All);
            self.queue.submit([enc.finish()]);
            self.read_back(&read, w, h, 4)
        })?;
        RgbaImage::from_raw(w, h, bytes)
            .ok_or_else(|| RenderError::Readback("image size mismatch".into()))
    }

    /// Draws the opacity-map pass and reads the 16 maps and the body depth map back (on
    /// adapters that cannot copy depth textures, GL, the body depth map is the CPU reference's).
    pub fn opacity_maps(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
    ) -> Result<OpacityMaps, RenderError> {
        let (prepared, g, lf) = self.setup(scene, settings)?;
        let size = settings.shadow.map_size;
        let maps = self.scoped(|| {
            // A 1x1 colour target: the shading pass is drawn but not read.
            let (frame, _u) = self.frame(&g, 1, 1);
            let view = frame.color.create_view(&Default::default());
            let mut enc = self.encode(&prepared, &frame, &view, true, [0.0; 3]);
            let reads: Vec<wgpu::Buffer> = frame
                .osm
                .iter()
                .map(|t| self.copy_out(&mut enc, t, size, size, 8, wgpu::TextureAspect::All))
                .collect();
            // GL lacks DownlevelFlags::DEPTH_TEXTURE_AND_BUFFER_COPIES.
            let depth_copies = self.info.backend != wgpu::Backend::Gl;
            let depth = depth_copies.then(|| {
                self.copy_out(
                    &mut enc,
                    &frame.osm_depth,
                    size,
                    size,
                    4,
                    wgpu::TextureAspect::DepthOnly,
                )
            });
            self.queue.submit([enc.finish()]);
            let mut maps = Vec::new();
            for r in &reads {
                maps.push(self.read_back(r, size, size, 8)?);
            }
            let depth = match depth {
                Some(d) => Some(self.read_back(&d, size, size, 4)?),
                None => None,
            };
            Ok((maps, depth))
        })?;
        let (maps, depth) = maps;
        let n = (size * size) as usize;
        let mut opacity = vec![[0.0f32; OSM_MAPS]; n];
        for (t, bytes) in maps.iter().enumerate() {
            for (i, texel) in opacity.iter_mut().enumerate() {
                for c in 0..4 {
                    let o = i * 8 + c * 2;
                    let h = u16::from_le_bytes([bytes[o], bytes[o + 1]]);
                    texel[4 * t + c] = f16_to_f32(h);
                }
            }
        }
        // Without depth-to-buffer copies (GL) the body depth map comes from the CPU rasteriser.
        let body_depth = match depth {
            Some(d) => d
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
            None => crate::cpu::body_depth_map(&g, &prepared),
        };
        Ok(OpacityMaps {
            size: size as usize,
            opacity,
            body_depth,
            frame: lf,
            globals: g,
        })
    }

    fn copy_out(
        &self,
        enc: &mut wgpu::CommandEncoder,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
        bpp: u32,
        aspect: wgpu::TextureAspect,
    ) -> wgpu::Buffer {
        let row = (w * bpp).div_ceil(256) * 256;
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: u64::from(row) * u64::from(h),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        buffer
    }

    fn read_back(
        &self,
        buffer: &wgpu::Buffer,
        w: u32,
        h: u32,
        bpp: u32,
    ) -> Result<Vec<u8>, RenderError> {
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        wait(&self.device)?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let row = ((w * bpp).div_ceil(256) * 256) as usize;
        let tight = (w * bpp) as usize;
        let data = buffer
            .slice(..)
            .get_mapped_range()
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let mut out = Vec::with_capacity(tight * h as usize);
        for y in 0..h as usize {
            out.extend_from_slice(&data[y * row..y * row + tight]);
        }
        drop(data);
        buffer.unmap();
        Ok(out)
    }
}
