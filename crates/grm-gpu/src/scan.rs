//! Exclusive scan on the GPU (block scan + recursion over block sums).

use crate::device::Gpu;
use crate::error::GpuError;
use crate::kernels;
use crate::layout::{SCAN_BLOCK, ScanParams};
use crate::shader::Kernel;

/// The element type of a scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanElem {
    /// `u32`.
    U32,
    /// `vec2<u32>`: two independent sums at once (modules and parameters).
    U32x2,
    /// [`crate::layout::TurtleElem`]: segmented composition of turtle
    /// transforms (inclusive).
    Turtle,
}

impl ScanElem {
    fn bytes(self) -> u64 {
        match self {
            ScanElem::U32 => 4,
            ScanElem::U32x2 => 8,
            ScanElem::Turtle => std::mem::size_of::<crate::layout::TurtleElem>() as u64,
        }
    }

    fn kernels(self) -> (&'static Kernel, &'static Kernel) {
        match self {
            ScanElem::U32 => (&kernels::SCAN_U32, &kernels::ADD_U32),
            ScanElem::U32x2 => (&kernels::SCAN_U32X2, &kernels::ADD_U32X2),
            ScanElem::Turtle => (&kernels::SCAN_TURTLE, &kernels::ADD_TURTLE),
        }
    }
}

/// Record an in-place scan of the first `n` elements of `data`: exclusive
/// sums for `U32`/`U32x2` (saturating at `u32::MAX` per component; put a
/// zero after the last count and scan `n + 1` elements to get the total in
/// element `n`), inclusive segmented composition for `Turtle`.
pub(crate) fn record_scan(
    gpu: &Gpu,
    encoder: &mut wgpu::CommandEncoder,
    elem: ScanElem,
    data: &wgpu::Buffer,
    n: u64,
) -> Result<(), GpuError> {
    if n == 0 {
        return Ok(());
    }
    if n > u64::from(u32::MAX) {
        return Err(GpuError::CountOverflow {
            what: "scan length",
            count: n,
        });
    }
    let blocks = n.div_ceil(u64::from(SCAN_BLOCK));
    let sums = gpu.storage("scan block sums", blocks * elem.bytes())?;
    let params = gpu.uniform(
        "scan params",
        &ScanParams {
            n: n as u32,
            blocks: blocks as u32,
            ..ScanParams::default()
        },
    );
    let (scan, add) = elem.kernels();
    gpu.dispatch(encoder, scan, &[&params, data, &sums], blocks)?;
    if blocks > 1 {
        record_scan(gpu, encoder, elem, &sums, blocks)?;
        gpu.dispatch(encoder, add, &[&params, data, &sums], blocks)?;
    }
    // Dead after the dispatches just recorded; later ones may reuse it.
    gpu.recycle([sums]);
    Ok(())
}

/// Scan a host array on the GPU and return the exclusive prefix sums
/// (for tests and benchmarks).
pub fn exclusive_scan_u32(gpu: &Gpu, values: &[u32]) -> Result<Vec<u32>, GpuError> {
    gpu.run(|| {
        let buf = gpu.upload("scan input", values)?;
        let mut enc = gpu.encoder();
        record_scan(gpu, &mut enc, ScanElem::U32, &buf, values.len() as u64)?;
        let mut out = gpu.read::<u32>(enc, &[(&buf, 0, values.len() as u64)])?;
        Ok(out.pop().unwrap_or_default())
    })
}

/// As [`exclusive_scan_u32`] for pairs, each component scanned separately.
pub fn exclusive_scan_u32x2(gpu: &Gpu, values: &[[u32; 2]]) -> Result<Vec<[u32; 2]>, GpuError> {
    gpu.run(|| {
        let buf = gpu.upload("scan input", values)?;
        let mut enc = gpu.encoder();
        record_scan(gpu, &mut enc, ScanElem::U32x2, &buf, values.len() as u64)?;
        let mut out = gpu.read::<[u32; 2]>(enc, &[(&buf, 0, values.len() as u64)])?;
        Ok(out.pop().unwrap_or_default())
    })
}

/// Inclusive segmented composition of turtle transforms on the GPU (for
/// tests): element `k` becomes the composition of its segment's elements
/// up to and including `k` (see `shaders/turtle_scan.wgsl`).
pub fn inclusive_scan_turtle(
    gpu: &Gpu,
    values: &[crate::layout::TurtleElem],
) -> Result<Vec<crate::layout::TurtleElem>, GpuError> {
    gpu.run(|| {
        let buf = gpu.upload("scan input", values)?;
        let mut enc = gpu.encoder();
        record_scan(gpu, &mut enc, ScanElem::Turtle, &buf, values.len() as u64)?;
        let mut out =
            gpu.read::<crate::layout::TurtleElem>(enc, &[(&buf, 0, values.len() as u64)])?;
        Ok(out.pop().unwrap_or_default())
    })
}
