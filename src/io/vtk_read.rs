//! VTK readers (legacy and XML).
