//! `stratasweep generate`: synthetic grids.

use super::checks::{self as cli_checks};
use super::common::*;
use anyhow::Context;
use anyhow::Result;
use anyhow::bail;
use clap::Subcommand;
use std::path::Path;
use std::path::PathBuf;
use std::time::Instant;
use stratasweep::generate;
use stratasweep::grid::Grid;
use stratasweep::io;
use stratasweep::io::guard::{Named, check_outputs};

#[derive(Subcommand)]
pub(crate) enum GenCmd {
    /// A smoothly warped, non-axis-aligned curvilinear grid with the Marschner–Lobb signal `f` (.vts).
    Warped {
        /// Cells per axis NI,NJ,NK.
        #[arg(long)]
        dims: String,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .vts.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A clipped 3D Voronoi grid of random sites in the unit box: conforming VTK polyhedra with a smooth point property `f` (.vtu).
    Voronoi {
        /// Number of cells (sites).
        #[arg(long)]
        cells: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .vtu.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A faulted corner-point reservoir (folded layers, faults with throw, pinch-outs, inactive cells, PORO) as GRDECL.
    Faulted {
        /// Cells NI,NJ,NK.
        #[arg(long)]
        dims: String,
        /// Number of faults.
        #[arg(long, default_value_t = 3)]
        faults: usize,
        /// Dip of every fault in degrees (45–90; 90 = vertical). Default: the
        /// first fault vertical, the others inclined 50–80°.
        #[arg(long)]
        fault_dip: Option<f64>,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .grdecl.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A conforming mixed tet/pyramid/wedge/hex grid with a noisy point property `f` (.vtu).
    Zoo {
        /// Approximate cell count.
        #[arg(long)]
        cells: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output .vtu.
        #[arg(short, long)]
        output: PathBuf,
    },
}

pub(crate) fn parse_dims(s: &str) -> Result<[usize; 3]> {
    let v: Vec<usize> = s
        .split(',')
        .map(|x| x.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--dims '{s}': expected NI,NJ,NK"))?;
    if v.len() != 3 || v.contains(&0) {
        bail!("--dims '{s}': expected three positive integers NI,NJ,NK");
    }
    if v.iter().map(|&d| (d + 1) as u128).product::<u128>() >= u32::MAX as u128 / 2 {
        bail!("--dims '{s}': too many points");
    }
    Ok([v[0], v[1], v[2]])
}

pub(crate) fn write_grid(path: &Path, grid: &Grid, want_ext: &str, quiet: bool) -> Result<()> {
    cli_checks::output_ext("-o", path, &[want_ext])?;
    let sp = spinner(quiet, format!("writing {}", path.display()));
    io::writers::write_vtk_xml_grid(path, grid)?;
    sp.finish_and_clear();
    if !quiet {
        eprintln!(
            "wrote {} ({} points, {} cells)",
            path.display(),
            grid.points.len(),
            grid.cell_count()
        );
    }
    Ok(())
}

/// Before anything is generated: refuses `-o` (and, for an EGRID, the
/// INIT written beside it) when it exists and is not a regular file.
fn check_output(g: &GenCmd) -> Result<()> {
    let out = match g {
        GenCmd::Warped { output, .. }
        | GenCmd::Voronoi { output, .. }
        | GenCmd::Faulted { output, .. }
        | GenCmd::Zoo { output, .. } => output,
    };
    let mut outputs = vec![Named::new("-o", out)];
    if matches!(g, GenCmd::Faulted { .. })
        && out
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("egrid"))
    {
        outputs.push(Named::new(
            "the INIT written beside -o",
            super::write::init_beside(out),
        ));
    }
    Ok(check_outputs(&outputs, &[])?)
}

pub(crate) fn cmd_generate(g: GenCmd, quiet: bool) -> Result<()> {
    check_output(&g)?;
    match g {
        GenCmd::Warped { dims, seed, output } => {
            let d = parse_dims(&dims)?;
            let grid = generate::warped(d, seed);
            write_grid(&output, &grid, "vts", quiet)
        }
        GenCmd::Faulted {
            dims,
            faults,
            fault_dip,
            seed,
            output,
        } => {
            let ext = cli_checks::output_ext("-o", &output, super::write::CORNERPOINT_EXTS)?;
            let d = parse_dims(&dims)?;
            if faults > 1000 {
                bail!("--faults must be at most 1000");
            }
            if let Some(dip) = fault_dip
                && !(generate::MIN_FAULT_DIP..=90.0).contains(&dip)
            {
                bail!(
                    "--fault-dip {dip} is outside [{}, 90] degrees",
                    generate::MIN_FAULT_DIP
                );
            }
            let g = generate::faulted_with_dip(d, faults, fault_dip, seed);
            let sp = spinner(quiet, format!("writing {}", output.display()));
            let cells = g.cell_count();
            let wrote = super::write::write_cornerpoint(&output, &ext, g)?;
            sp.finish_and_clear();
            if !quiet {
                eprintln!(
                    "wrote {} ({cells} cells, {faults} faults)",
                    wrote.join(" and ")
                );
            }
            Ok(())
        }
        GenCmd::Zoo {
            cells,
            seed,
            output,
        } => {
            if cells == 0 || cells > 200_000_000 {
                bail!("--cells must be between 1 and 200000000");
            }
            let grid = generate::zoo(cells, seed);
            write_grid(&output, &grid, "vtu", quiet)
        }
        GenCmd::Voronoi {
            cells,
            seed,
            output,
        } => {
            if cells == 0 || cells > 50_000_000 {
                bail!("--cells must be between 1 and 50000000");
            }
            let t = Instant::now();
            let grid = stratasweep::voronoi::voronoi(cells, seed);
            if !quiet {
                eprintln!(
                    "voronoi: {cells} cells, {} vertices in {:.2} s",
                    grid.points.len(),
                    t.elapsed().as_secs_f64()
                );
            }
            write_grid(&output, &grid, "vtu", quiet)
        }
    }
}
