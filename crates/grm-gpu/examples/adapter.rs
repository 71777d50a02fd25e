//! Print the GPU adapter the engine would use and its limits.
//!
//!     cargo run -p grm-gpu --example adapter

fn main() {
    match grm_gpu::shared() {
        Ok(g) => {
            println!("{}", g.describe());
            let l = g.limits();
            println!(
                "max_storage_buffer_binding_size {}",
                l.max_storage_buffer_binding_size
            );
            println!("max_buffer_size {}", l.max_buffer_size);
            println!(
                "max_compute_workgroups_per_dimension {}",
                l.max_compute_workgroups_per_dimension
            );
            println!(
                "max_storage_buffers_per_shader_stage {}",
                l.max_storage_buffers_per_shader_stage
            );
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
