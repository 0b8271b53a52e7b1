//! The error of every render: a refused request, a device failure, a bad
//! option or a transfer function that can only draw nothing.

use thiserror::Error;

use crate::gpu::context::GpuError;
use crate::pipeline::PipelineError;

use super::transfer::TransferError;

/// Errors of rendering.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The pipeline refused the request.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The GPU failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A bad option.
    #[error("{0}")]
    Options(String),
    /// A transfer function that is malformed or can only draw nothing.
    #[error(transparent)]
    Transfer(#[from] TransferError),
}
