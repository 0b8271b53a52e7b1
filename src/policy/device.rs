//! Where work runs: `slice`'s device (the CPU sweep emits the polygons,
//! or the GPU does, or the GPU when there is one) checked against the
//! request and the structure, and the adapter a render asks for when told
//! to use hardware or software only.

use super::{Message, Opt, PolicyError, Refusal, Value};
use crate::gpu::context::GpuError;
use crate::structures::{Structure, StructureChoice};

/// Where polygons are generated (slicing) or images drawn (rendering).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// The CPU sweep emits the polygons; renders on a software rasteriser.
    Cpu,
    /// The CPU sweep finds the cut cells, the GPU emits them (statistics
    /// only); renders on a hardware adapter.
    Gpu,
    /// The GPU when there is one (and the request allows it), else the CPU.
    Auto,
}

/// The names of the devices.
pub const DEVICES: [(&str, Device); 3] = [
    ("cpu", Device::Cpu),
    ("gpu", Device::Gpu),
    ("auto", Device::Auto),
];

fn cpu_only() -> Value {
    Value::Word("cpu")
}

/// The device of a slicing request, before the structure is built: the
/// GPU path gives statistics, not polygons, and does not run the brute
/// force; a request for polygons or the brute force runs on the CPU.
pub fn slice_device(d: Device, mesh: bool, choice: StructureChoice) -> Result<Device, PolicyError> {
    let brute = choice == StructureChoice::BruteForce;
    if d == Device::Gpu && mesh {
        return Err(PolicyError::invalid(
            Message::new()
                .opt_is(Opt::Device, Value::Word("gpu"))
                .text(" gives statistics and draws, not polygons: ask for no mesh (")
                .opt_is(Opt::Mesh, Value::Bool(false))
                .text(") or use ")
                .opt_is(Opt::Device, cpu_only()),
        ));
    }
    if d == Device::Gpu && brute {
        return Err(PolicyError::invalid(
            Message::new()
                .opt_is(Opt::Structure, Value::Word("bruteforce"))
                .text(" runs on the CPU only"),
        ));
    }
    Ok(if mesh || brute { Device::Cpu } else { d })
}

/// The device on the built structure: the GPU tables cover S-CGraph,
/// CGraph and CP-Graph grids; CIEL grids stay on the CPU (refused when
/// the GPU was asked for).
pub fn slice_device_on(d: Device, s: &Structure) -> Result<Device, PolicyError> {
    match (d, s) {
        (Device::Auto, Structure::Ciel(_)) => Ok(Device::Cpu),
        (Device::Gpu, Structure::Ciel(_)) => Err(PolicyError::invalid(
            Message::new()
                .text(
                    "the GPU path takes S-CGraph and CGraph grids; this grid needs CIEL \
                     (polyhedra with more than 12 vertices): use ",
                )
                .opt_is(Opt::Device, cpu_only()),
        )),
        _ => Ok(d),
    }
}

/// Whether a device that failed to open with `e` means the CPU path
/// instead: `auto` without any adapter.
pub fn falls_back(d: Device, e: &GpuError) -> bool {
    d == Device::Auto && matches!(e, GpuError::NoAdapter { .. })
}

/// An adapter as wgpu lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterInfo {
    /// Name with backend, as `GpuContext` names it.
    pub name: String,
    /// Backend (`Vulkan`, `Gl`, ...).
    pub backend: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` or `Other`.
    pub device_type: String,
}

/// The adapters a render chooses among: the primary backends', or GL's
/// when they have none.
pub fn adapters() -> Vec<AdapterInfo> {
    crate::gpu::context::list_adapters(None)
        .into_iter()
        .map(|i| AdapterInfo {
            name: format!("{} ({:?})", i.name, i.backend),
            backend: format!("{:?}", i.backend),
            device_type: format!("{:?}", i.device_type),
        })
        .collect()
}

/// The adapter name a render asks for: `auto` leaves the choice to the
/// context (real GPUs before software ones) among those matching
/// `adapter`; `gpu` takes the first hardware adapter, `cpu` the first
/// software rasteriser (Mesa's llvmpipe), among `all`.
pub fn render_adapter(
    d: Device,
    adapter: Option<String>,
    all: &[AdapterInfo],
) -> Result<Option<String>, PolicyError> {
    let software = match d {
        Device::Auto => return Ok(adapter),
        Device::Gpu => false,
        Device::Cpu => true,
    };
    let found = all.iter().find(|a| {
        (a.device_type == "Cpu") == software
            && adapter
                .as_ref()
                .is_none_or(|w| a.name.to_lowercase().contains(&w.to_lowercase()))
    });
    if let Some(a) = found {
        return Ok(Some(a.name.clone()));
    }
    let listed: Vec<String> = all
        .iter()
        .map(|a| format!("{} [{}]", a.name, a.device_type))
        .collect();
    let text = format!(
        ": no {} adapter{} among [{}]; ",
        if software {
            "software (CPU)"
        } else {
            "hardware GPU"
        },
        adapter
            .map(|w| format!(" matching '{w}'"))
            .unwrap_or_default(),
        listed.join(", "),
    );
    let hint = match software {
        true => {
            " takes any adapter (install Mesa's software Vulkan: apt install mesa-vulkan-drivers)"
        }
        false => " takes any adapter",
    };
    Err(PolicyError {
        context: Message::new(),
        refusal: Refusal::Unavailable(
            Message::new()
                .opt_is(
                    Opt::Device,
                    Value::Word(if software { "cpu" } else { "gpu" }),
                )
                .text(text)
                .opt_is(Opt::Device, Value::Word("auto"))
                .text(hint),
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gpu_path_gives_statistics_on_the_graphs_it_covers() {
        let auto = StructureChoice::Auto;
        let e = slice_device(Device::Gpu, true, auto).unwrap_err();
        assert!(e.to_string().contains("mesh=False"), "{e}");
        assert!(e.to_string().contains("device='cpu'"), "{e}");
        let e = slice_device(Device::Gpu, false, StructureChoice::BruteForce).unwrap_err();
        assert_eq!(e.to_string(), "structure='bruteforce' runs on the CPU only");
        assert_eq!(slice_device(Device::Auto, true, auto).unwrap(), Device::Cpu);
        assert_eq!(
            slice_device(Device::Auto, false, auto).unwrap(),
            Device::Auto
        );
        let err = GpuError::NoAdapter {
            wanted: None,
            available: vec![],
            backends: None,
        };
        assert!(falls_back(Device::Auto, &err) && !falls_back(Device::Gpu, &err));
    }

    #[test]
    fn a_render_device_picks_hardware_or_software_adapters() {
        let a = |name: &str, t: &str| AdapterInfo {
            name: name.into(),
            backend: "Vulkan".into(),
            device_type: t.into(),
        };
        let all = [
            a("llvmpipe (Vulkan)", "Cpu"),
            a("H200 (Vulkan)", "DiscreteGpu"),
        ];
        assert_eq!(
            render_adapter(Device::Cpu, None, &all).unwrap().as_deref(),
            Some("llvmpipe (Vulkan)")
        );
        assert_eq!(
            render_adapter(Device::Gpu, None, &all).unwrap().as_deref(),
            Some("H200 (Vulkan)")
        );
        let e = render_adapter(Device::Gpu, None, &all[..1]).unwrap_err();
        assert!(matches!(e.refusal, Refusal::Unavailable(_)));
        assert!(
            e.to_string()
                .starts_with("device='gpu': no hardware GPU adapter among"),
            "{e}"
        );
    }
}
