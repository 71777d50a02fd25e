//! Run single bytecode expressions on the GPU interpreter (`shaders/vm.wgsl`),
//! for comparing it with the CPU VM of `grm-compile`.

use grm_compile::table::{PACKED_MAGIC, PackedHeader};

use crate::device::{Gpu, groups_for};
use crate::error::GpuError;
use crate::kernels;
use crate::layout::{MAX_BIND_WORDS, VmJob, VmResult};

/// Evaluate `jobs` against `code` and `consts` (packed into a table buffer
/// that has only those two sections). Returns one result per job.
pub fn eval(
    gpu: &Gpu,
    code: &[u32],
    consts: &[f32],
    binds: &[f32],
    jobs: &[VmJob],
) -> Result<Vec<VmResult>, GpuError> {
    if let Some(j) = jobs.iter().find(|j| j.bind_len > MAX_BIND_WORDS) {
        return Err(GpuError::Unsupported(format!(
            "{} binding words (the GPU limit is {MAX_BIND_WORDS})",
            j.bind_len
        )));
    }
    let header_words = (std::mem::size_of::<PackedHeader>() / 4) as u32;
    let header = PackedHeader {
        magic: PACKED_MAGIC,
        code_offset: header_words,
        code_count: code.len() as u32,
        consts_offset: header_words + code.len() as u32,
        consts_count: consts.len() as u32,
        ..bytemuck::Zeroable::zeroed()
    };
    let mut words: Vec<u32> = bytemuck::cast_slice(&[header]).to_vec();
    words.extend_from_slice(code);
    words.extend(consts.iter().map(|c| c.to_bits()));
    gpu.run(|| {
        let tables = gpu.upload("tables", &words)?;
        let jobs_buf = gpu.upload("vm jobs", jobs)?;
        let binds_buf = gpu.upload(
            "vm binds",
            if binds.is_empty() {
                &[0.0f32][..]
            } else {
                binds
            },
        )?;
        let out = gpu.storage(
            "vm results",
            (jobs.len() * std::mem::size_of::<VmResult>()) as u64,
        )?;
        let mut enc = gpu.encoder();
        gpu.dispatch(
            &mut enc,
            &kernels::VM_EVAL,
            &[&tables, &jobs_buf, &binds_buf, &out],
            groups_for(jobs.len() as u64),
        )?;
        let mut r = gpu.read::<VmResult>(enc, &[(&out, 0, jobs.len() as u64)])?;
        Ok(r.pop().unwrap_or_default())
    })
}
