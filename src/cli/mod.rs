//! The command-line interface: argument parsing (clap), process setup and the error chain; one module per command.

mod bench;
mod checks;
mod common;
mod device;
mod generate;
mod info;
mod render;
mod scene_args;
mod slice;
mod view;
mod write;

use anyhow::Result;
use bench::*;
use clap::Parser;
use clap::Subcommand;
use common::*;
use generate::*;
use info::*;
use render::*;
use slice::*;
use stratasweep::io;

#[derive(Parser)]
#[command(
    name = "stratasweep",
    version,
    about = "Incremental slicing and contouring of geological grids (Caumon et al. 2005)"
)]
struct Cli {
    /// No progress bars or chatter.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Print vertices, cells by type, the meta-cell catalog and memory per structure.
    Info(InfoArgs),
    /// Slice or contour a grid with the incremental sweep.
    Slice(SliceArgs),
    /// Write a synthetic grid.
    #[command(subcommand)]
    Generate(GenCmd),
    /// Benchmark the sweep against the brute-force reference (or, with --device, CPU against GPU emission).
    Bench(BenchArgs),
    /// Volume-render (or draw isosurfaces of) a grid on the GPU into a PNG.
    Render(RenderArgs),
    /// Open an interactive window (orbit, pan, zoom; egui panel) on a grid, drawn on the GPU.
    View(view::ViewArgs),
}

/// Runs the CLI: process setup, argument parsing, the command, the exit code.
pub fn main() {
    restore_default_sigpipe();
    tune_allocator();
    quiet_headless_vulkan_layer();
    remove_temporaries_on_signals();
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        // Messages may quote file content: never send raw control bytes.
        eprintln!("error: {}", io::checks::escape_control(&error_chain(&e)));
        std::process::exit(1);
    }
}

/// Lets a closed stdout end the process quietly, as it does for other
/// command-line tools (`stratasweep info G --json | head -1`): Rust ignores
/// SIGPIPE, which turns the write into a panic in `println!`.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists;
    // SIG_DFL is a valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// On SIGINT, SIGTERM or SIGHUP: removes the temporary files of the
/// outputs being written (`io::atomic::remove_temporaries`: the
/// destinations stay as they were), then ends the process by the same
/// signal, as its default action would (a shell sees 128 + the signal, and
/// a script looping over runs stops on Ctrl-C). A signal that was ignored
/// when the process started (`nohup`, a background job) stays ignored. The
/// signal is taken by a thread of its own (signal-hook's iterator), so the
/// clean-up runs outside any asynchronous signal handler.
fn remove_temporaries_on_signals() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let wanted: Vec<i32> = [SIGINT, SIGTERM, SIGHUP]
            .into_iter()
            .filter(|&s| !ignored_at_start(s))
            .collect();
        let Ok(mut signals) = signal_hook::iterator::Signals::new(&wanted) else {
            return;
        };
        let spawned = std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    io::atomic::remove_temporaries();
                    let _ = signal_hook::low_level::emulate_default_handler(sig);
                    std::process::exit(128 + sig);
                }
            });
        drop(spawned);
    }
}

/// Whether `sig`'s disposition is "ignore" (inherited across exec).
#[cfg(unix)]
fn ignored_at_start(sig: i32) -> bool {
    // SAFETY: a query (null new action) into a zeroed sigaction.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(sig, std::ptr::null(), &mut old) == 0 && old.sa_sigaction == libc::SIG_IGN
    }
}

/// Turns off Mesa's Vulkan device-selection layer on machines without a
/// desktop session (no `XDG_RUNTIME_DIR`: servers, containers, CI), unless
/// the user configured it. The layer only reorders the adapter list, which
/// `GpuContext` sorts itself, but it connects to Wayland to do so and there
/// prints "error: XDG_RUNTIME_DIR is invalid or not set" twice per run: a
/// false alarm on the README's first command.
fn quiet_headless_vulkan_layer() {
    let set = |k: &str| std::env::var_os(k).is_some();
    if cfg!(target_os = "linux")
        && !set("XDG_RUNTIME_DIR")
        && !set("NODEVICE_SELECT")
        && !set("MESA_VK_DEVICE_SELECT")
    {
        // SAFETY: called first thing in main, before any thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// Tunes glibc's allocator for this process's pattern: arrays of tens to
/// hundreds of MiB that grow, are freed and are allocated again (parsing,
/// conversion, build, sweep buffers). By default each one above the dynamic
/// mmap threshold is a fresh mapping whose pages fault in again; kept in
/// the heap (freed memory above 256 MiB is still trimmed) they are reused.
/// Measured: parsing the generated 4M-cell GRDECL 592 MB/s instead of
/// 286 MB/s; with the same settings through `GLIBC_TUNABLES`, Reek `.DATA`
/// load + build had 3,530 page faults instead of 4,380.
fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: called first thing in main, before any thread or allocation
    // of ours; mallopt only changes allocator parameters.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_TOP_PAD, 32 << 20);
    }
}

/// The error and its causes joined by ": ", skipping a cause whose text
/// its predecessor already ends with (errors that print their source), and
/// a cause's leading X when the text so far ends with X and the cause goes
/// on with ':' ("cannot load a.vtk" then "a.vtk: invalid grid" or
/// "a.vtk:3: …" names the file once). Nothing is lost: the text so far
/// still ends with X.
fn error_chain(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if msg.ends_with(&c) {
            continue;
        }
        // The longest tail of msg after a space that c starts with, then ':'.
        let repeated = msg
            .match_indices(' ')
            .map(|(i, _)| &msg[i + 1..])
            .find(|tail| {
                !tail.is_empty() && c.starts_with(tail) && c[tail.len()..].starts_with(':')
            })
            .map_or(0, str::len);
        if repeated == 0 {
            msg.push_str(": ");
            msg.push_str(&c);
        } else {
            msg.push_str(&c[repeated..]);
        }
    }
    msg
}

fn run(cli: Cli) -> Result<()> {
    let quiet = cli.quiet;
    match cli.cmd {
        Cmd::Info(a) => cmd_info(a),
        Cmd::Slice(a) => cmd_slice(a, quiet),
        Cmd::Generate(g) => {
            crate::oom_context("generating the grid");
            cmd_generate(g, quiet)
        }
        Cmd::Bench(a) => cmd_bench(a, quiet),
        Cmd::Render(a) => cmd_render(a, quiet),
        Cmd::View(a) => view::cmd_view(a, quiet),
    }
}
