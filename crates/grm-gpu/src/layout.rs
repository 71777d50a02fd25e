//! Structs shared by Rust and WGSL, and the generated WGSL header.
//!
//! Each struct is declared once, with `gpu_struct!`, which defines the
//! `#[repr(C)]` Pod Rust type and the WGSL declaration from the same field
//! list; a test parses the header with naga and checks that every member
//! offset and every struct size agree with `std::mem::offset_of!` and
//! `size_of`.

/// A struct that exists on both sides.
pub trait GpuStruct: bytemuck::Pod {
    /// The WGSL (and Rust) type name.
    const NAME: &'static str;
    /// The WGSL declaration.
    fn wgsl() -> String;
    /// Rust member names and byte offsets, in declaration order.
    fn offsets() -> Vec<(&'static str, usize)>;
}

/// Declare a struct shared with WGSL: `field: RustType => "wgsl type"`.
macro_rules! gpu_struct {
    ($(#[$m:meta])* pub struct $name:ident { $( $(#[$fm:meta])* pub $f:ident : $t:ty => $w:literal ),* $(,)? }) => {
        $(#[$m])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name { $( $(#[$fm])* pub $f: $t ),* }

        impl $crate::layout::GpuStruct for $name {
            const NAME: &'static str = stringify!($name);
            fn wgsl() -> String {
                let mut s = format!("struct {} {{\n", stringify!($name));
                $( s.push_str(&format!("    {}: {},\n", stringify!($f), $w)); )*
                s.push_str("}\n");
                s
            }
            fn offsets() -> Vec<(&'static str, usize)> {
                vec![$( (stringify!($f), std::mem::offset_of!($name, $f)) ),*]
            }
        }
    };
}
#[allow(unused_imports)]
pub(crate) use gpu_struct;

/// Mirror a record type of `grm-compile` in WGSL: the WGSL struct is
/// generated from this field list and the offsets are taken from the real
/// Rust type with `offset_of!`, so a renamed field fails to compile and a
/// moved, added or retyped one fails the layout test. Also generates a WGSL
/// loader `load_NAME(word_index) -> NAME` that reads the record from the
/// packed `tables: array<u32>` buffer.
macro_rules! mirror_struct {
    ($ty:path as $name:ident { $( $f:ident : $w:ident ),* $(,)? }) => {{
        let mut wgsl = format!("struct {} {{\n", stringify!($name));
        $( wgsl.push_str(&format!("    {}: {},\n", stringify!($f), stringify!($w))); )*
        wgsl.push_str("}\n");
        let mut loader = format!("fn load_{}(b: u32) -> {} {{\n    return {}(", stringify!($name), stringify!($name), stringify!($name));
        let mut k = 0u32;
        $(
            if k > 0 { loader.push_str(", "); }
            match stringify!($w) {
                "f32" => loader.push_str(&format!("bitcast<f32>(tables[b + {k}u])")),
                _ => loader.push_str(&format!("tables[b + {k}u]")),
            }
            k += 1;
        )*
        loader.push_str(");\n}\n");
        let mut store = format!("fn store_{}(b: u32, v: {}) {{\n", stringify!($name), stringify!($name));
        let mut k = 0u32;
        $(
            match stringify!($w) {
                "f32" => store.push_str(&format!("    tables[b + {k}u] = bitcast<u32>(v.{});\n", stringify!($f))),
                _ => store.push_str(&format!("    tables[b + {k}u] = v.{};\n", stringify!($f))),
            }
            k += 1;
        )*
        store.push_str("}\n");
        let _ = k;
        Mirror {
            info: StructInfo {
                name: stringify!($name),
                wgsl,
                size: std::mem::size_of::<$ty>(),
                offsets: vec![$( (stringify!($f), std::mem::offset_of!($ty, $f)) ),*],
            },
            loader,
            store,
        }
    }};
}

/// A record the kernels read from the `tables` buffer: its layout, its
/// WGSL loader and store (the store only in kernels that may write).
#[derive(Clone, Debug)]
pub struct Mirror {
    pub info: StructInfo,
    pub loader: String,
    pub store: String,
}

/// One system of a (multi-system) derivation: the directory entry at the
/// start of the `tables` buffer (Lipp 5.4's lookup table).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SystemEntry {
    /// Word offset of the system's packed tables in `tables`.
    pub base: u32,
    /// Its iterations: later iterations copy its modules unchanged.
    pub iterations: u32,
    pub seed: u32,
    /// Its first module in the current string.
    pub start: u32,
    /// One past its last module.
    pub end: u32,
    /// The root key of its derivation (`CompiledSystem::root_key(seed)`):
    /// the parent key of its axiom's modules and the key of the axiom's
    /// draws (`grm_compile::rng`, "Identity keys").
    pub root_key: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// Symbols carry their system's index above this bit (multi-system strings).
pub const SYS_SHIFT: u32 = 20;
/// The symbol id within its system.
pub const SYM_MASK: u32 = (1 << SYS_SHIFT) - 1;
/// The most systems one derivation may hold.
pub const MAX_SYSTEMS: usize = 1 << (32 - SYS_SHIFT);

/// The system directory record.
pub fn directory_mirror() -> Mirror {
    mirror_struct!(SystemEntry as SystemEntry {
        base: u32, iterations: u32, seed: u32, start: u32, end: u32, root_key: u32, pad1: u32, pad2: u32,
    })
}

use crate::device::WORKGROUP;
use grm_compile::op::{Op, STACK_SIZE};
use grm_compile::table as t;

/// Largest binding array (words) a production may use on the GPU (a
/// private array in the kernels; larger groups are refused on the host).
pub const MAX_BIND_WORDS: u32 = 32;

/// The packed-table records the kernels read, mirrored from `grm_compile::table`.
pub fn mirrors() -> Vec<Mirror> {
    vec![
        mirror_struct!(t::PackedHeader as PackedHeader {
            magic: u32, symbols_offset: u32, symbols_count: u32, groups_offset: u32,
            groups_count: u32, alts_offset: u32, alts_count: u32, context_offset: u32,
            context_count: u32, succ_offset: u32, succ_count: u32, params_offset: u32,
            params_count: u32, code_offset: u32, code_count: u32, consts_offset: u32,
            consts_count: u32, axiom_alt: u32, seed: u32, iterations: u32,
            log2_offset: u32, log2_count: u32,
        }),
        mirror_struct!(t::SymbolEntry as SymbolEntry {
            first_group: u32, group_count: u32, first_wrapup: u32, wrapup_count: u32,
            param_words: u32, flags: u32,
        }),
        mirror_struct!(t::GroupHeader as GroupHeader {
            pred: u32, flags: u32, left_offset: u32, left_len: u32, right_offset: u32,
            right_len: u32, bind_words: u32, pred_bind_offset: u32, pred_bind_words: u32,
            cond_code: u32, first_alt: u32, alt_count: u32, total_weight: f32, sema_group: u32,
        }),
        mirror_struct!(t::AltHeader as AltHeader {
            group: u32, weight_code: u32, weight: f32, cum_weight: f32, succ_offset: u32,
            succ_len: u32, succ_words: u32, flags: u32,
        }),
        mirror_struct!(t::ContextItem as ContextItem {
            kind: u32, symbol: u32, bind_words: u32, bind_offset: u32,
        }),
        mirror_struct!(t::SuccModule as SuccModule {
            symbol: u32, first_param: u32, param_count: u32, word_offset: u32, salt: u32,
        }),
        mirror_struct!(t::ParamExpr as ParamExpr {
            kind: u32, a: u32, words: u32, span: u32,
        }),
        directory_mirror(),
    ]
}

/// `RandUniform` -> `RAND_UNIFORM`.
fn screaming(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}

/// The WGSL name of an op's opcode constant (`OP_RAND_UNIFORM`).
pub fn op_const_name(op: Op) -> String {
    format!("OP_{}", screaming(&format!("{op:?}")))
}

/// `f32` as a WGSL literal that parses back to the same bits.
fn f32_lit(x: f32) -> String {
    format!("{x:?}f")
}

/// The packed-table code generated for kernels that bind `tables`: the
/// record loaders and `TAB`, the header of the loaded program.
pub fn wgsl_tables() -> String {
    let mut s = String::from("// ---- generated by grm-gpu: packed-table loaders\n");
    for m in mirrors() {
        s.push_str(&m.loader);
    }
    s.push_str("var<private> TAB: PackedHeader;\n");
    s.push_str("// Word offset of the current system's packed tables (TAB's own position).\n");
    s.push_str("var<private> TAB_BASE: u32;\n");
    s.push_str(
        "fn tab_select(base: u32) {\n    TAB_BASE = base;\n    TAB = load_PackedHeader(base);\n}\n",
    );
    s
}

/// The directory store, for the one kernel that updates it.
pub fn wgsl_directory_store() -> String {
    directory_mirror().store
}

/// Elements each scan thread handles serially.
pub const SCAN_PER_THREAD: u32 = 4;
/// Elements per scan block (one workgroup).
pub const SCAN_BLOCK: u32 = WORKGROUP * SCAN_PER_THREAD;

gpu_struct! {
    /// Parameters of one scan level.
    pub struct ScanParams {
        /// Elements at this level.
        pub n: u32 => "u32",
        /// Blocks (workgroups) at this level.
        pub blocks: u32 => "u32",
        pub pad0: u32 => "u32",
        pub pad1: u32 => "u32",
    }
}

/// One shared struct: name, WGSL declaration, Rust size and member offsets.
#[derive(Clone, Debug)]
pub struct StructInfo {
    pub name: &'static str,
    pub wgsl: String,
    pub size: usize,
    pub offsets: Vec<(&'static str, usize)>,
}

gpu_struct! {
    /// One expression evaluation of the VM test kernel.
    pub struct VmJob {
        pub entry: u32 => "u32",
        pub bind_first: u32 => "u32",
        pub bind_len: u32 => "u32",
        pub seed: u32 => "u32",
        pub iteration: u32 => "u32",
        pub position: u32 => "u32",
    }
}

gpu_struct! {
    /// The result of a [`VmJob`]: words left (or `u32::MAX` on a fault)
    /// and up to three of them.
    pub struct VmResult {
        pub words: u32 => "u32",
        pub x: f32 => "f32",
        pub y: f32 => "f32",
        pub z: f32 => "f32",
    }
}

gpu_struct! {
    /// Parameters of one derivation dispatch (`count`, `rewrite`).
    pub struct DeriveParams {
        /// Input modules (1 for the axiom).
        pub n: u32 => "u32",
        /// Input parameter words.
        pub words: u32 => "u32",
        /// Systems in the directory.
        pub systems: u32 => "u32",
        /// The index of the string being produced (0: the axiom).
        pub iteration: u32 => "u32",
        /// 1: write the axiom instead of rewriting the input.
        pub axiom: u32 => "u32",
        /// 1: the strings carry identity keys (`in_keys`, `out_keys`):
        /// draws are keyed by them and the rewrite writes them; 0: no
        /// system draws, the key buffers are not read or written.
        pub keyed: u32 => "u32",
        pub pad1: u32 => "u32",
        pub pad2: u32 => "u32",
    }
}

gpu_struct! {
    /// Constants of a batched derivation's `batch_next` kernel
    /// (`shaders/batch.wgsl`).
    pub struct BatchParams {
        /// Workgroups per grid dimension of the indirect dispatches.
        pub grid_width: u32 => "u32",
        /// Scan levels recorded (for the largest input).
        pub levels: u32 => "u32",
        /// Where the overflow flag is in the history buffer.
        pub flag: u32 => "u32",
        /// `ScanParams` records from one scan level's parameters to the
        /// next (binding offsets must be aligned).
        pub sp_stride: u32 => "u32",
    }
}

gpu_struct! {
    /// Parameters of the direct derivation's `expand` kernel
    /// (`shaders/expand.wgsl`).
    pub struct ExpandParams {
        /// Modules of string 0 (the axioms).
        pub n_in: u32 => "u32",
        /// Modules of the final string: one thread each.
        pub total: u32 => "u32",
        /// Parameter words of the final string.
        pub total_words: u32 => "u32",
        /// 1: write the final string's identity keys (from the axiom
        /// modules' keys and the slots' salts); 0: no system draws.
        pub keyed: u32 => "u32",
    }
}

/// Words of one successor slot in the expansion tables: its symbol, its
/// parameter words, where its constant parameters are in the expansion
/// tables (`NONE`: computed), its first parameter expression and their
/// count in its system's parameter table, where its predecessor's
/// parameters are bound for them (binding word, words), and its identity
/// salt (`SuccModule::salt`).
pub const EXPAND_SLOT_WORDS: u32 = 8;

/// The most rewriting steps a direct derivation takes: each output module
/// walks down one tree level per step, so a long derivation of a slowly
/// growing string (`A -> F A` for thousands of steps) is cheaper stepwise.
pub const DIRECT_MAX_STEPS: u32 = 64;

/// The deepest bracket nesting within one successor (or the axiom) that
/// the direct interpretation's table kernel keeps states for.
pub const DIRECT_TURTLE_STACK: u32 = 16;

gpu_struct! {
    /// One job of a direct derivation: where its expansion tables are in
    /// the `expand` kernel's table buffer (word indices). Symbol `s` has
    /// the record `(first slot, successor length)` at `symbols + 2 s`
    /// (length 0: the symbol stays itself). Slot `f + i` (successor module
    /// `i` of the symbol whose first slot is `f`) is a record of
    /// [`EXPAND_SLOT_WORDS`] words at
    /// `slots + EXPAND_SLOT_WORDS (f + i)`; with `r` steps left
    /// (1 ..= steps), the pair (first module, first parameter word) of
    /// that module's expansion inside its predecessor's is at
    /// `offsets + 2 ((r - 1) slot_count + f + i)`.
    pub struct ExpandJob {
        pub symbols: u32 => "u32",
        pub slots: u32 => "u32",
        pub offsets: u32 => "u32",
        /// Successor slots of the job's system.
        pub slot_count: u32 => "u32",
        /// The job's rewriting steps.
        pub steps: u32 => "u32",
        pub pad0: u32 => "u32",
        pub pad1: u32 => "u32",
        pub pad2: u32 => "u32",
    }
}

gpu_struct! {
    /// Parameters of the direct interpretation (`shaders/expand_turtle.wgsl`)
    /// of one job's direct derivation: the expansion tables' places (as
    /// [`ExpandJob`]), the sizes, and where each table starts in the
    /// `nets` (turtle transforms) and `ft` (bone counts) buffers.
    pub struct ExpandTurtleParams {
        pub symbols: u32 => "u32",
        pub slots: u32 => "u32",
        pub offsets: u32 => "u32",
        pub slot_count: u32 => "u32",
        pub steps: u32 => "u32",
        /// Symbols of the system.
        pub nsym: u32 => "u32",
        /// Axiom modules (after the slots in the slot string).
        pub n_ax: u32 => "u32",
        /// Bones to write: one thread each.
        pub bones: u32 => "u32",
        /// `nets`: each slot's and axiom module's own transform from 0,
        /// then per step `r` every symbol's whole expansion (`net_n`), every
        /// slot's prefix within its predecessor's (`net_p`), and the prefix
        /// before each axiom module (`net_ax`).
        pub net_n: u32 => "u32",
        pub net_p: u32 => "u32",
        pub net_ax: u32 => "u32",
        /// `ft`: per symbol whether it has a production from 0; per step and
        /// slot the bones before it in its predecessor's expansion
        /// (`f_pre`); the bones before each axiom module's expansion and the
        /// total (`f_top`); each axiom module's first output module
        /// (`m_top`).
        pub f_pre: u32 => "u32",
        pub f_top: u32 => "u32",
        pub m_top: u32 => "u32",
        pub pad0: u32 => "u32",
        pub pad1: u32 => "u32",
    }
}

/// Fan-out of the bracket-matching minimum tree.
pub const BRACKET_FAN: u32 = 32;
/// Levels the bracket tree may have (`offs`/`lens` entries).
pub const BRACKET_MAX_LEVELS: usize = 8;

gpu_struct! {
    /// Parameters of the bracket-matching kernels: the level table of the
    /// minimum tree in the `levels` buffer.
    pub struct BracketParams {
        /// Modules.
        pub n: u32 => "u32",
        /// The level `bracket_reduce` reads.
        pub level: u32 => "u32",
        /// Levels in use.
        pub levels: u32 => "u32",
        pub pad0: u32 => "u32",
        /// Start of each level in `levels` (`offs[l / 4][l % 4]`).
        pub offs: [[u32; 4]; 2] => "array<vec4<u32>, 2>",
        /// Length of each level.
        pub lens: [[u32; 4]; 2] => "array<vec4<u32>, 2>",
    }
}

/// Error bits of the derivation status buffer (`status[2 * slot + 1]`).
pub const ERR_BAD_WEIGHT: u32 = 1;
pub const ERR_FAULT: u32 = 2;
pub const ERR_NON_FINITE: u32 = 4;
/// Words of the derivation status buffer: per slot (count, rewrite) the
/// inverted lowest failing position and the error bits.
pub const STATUS_WORDS: u32 = 4;

gpu_struct! {
    /// A module symbol's turtle command (per symbol id, see `interp`).
    pub struct TurtleSym {
        /// A `TOP_*` code ([`crate::interp::TurtleOp`]).
        pub op: u32 => "u32",
        /// +1 or -1: the direction of a rotation (`+` is `rotz(-a)`).
        pub sign: f32 => "f32",
    }
}

gpu_struct! {
    /// Parameters of the interpretation kernels.
    pub struct TurtleParams {
        pub n: u32 => "u32",
        /// The deepest depth.
        pub dmax: u32 => "u32",
        /// Modules per histogram chunk.
        pub chunk: u32 => "u32",
        pub chunks: u32 => "u32",
        /// The depth of this round.
        pub depth: u32 => "u32",
        /// Where the bucket bounds start in `aux`.
        pub bstart: u32 => "u32",
        /// Where the indirect dispatch arguments start in `aux`.
        pub args: u32 => "u32",
        /// Workgroups per grid dimension.
        pub max_groups: u32 => "u32",
        /// 1: no module is a bracket (depth 0 everywhere; the depth order
        /// is the string order, so no depths are computed and nothing is
        /// sorted).
        pub straight: u32 => "u32",
        /// 1: every command affine and the matrix scan fused
        /// (`fused_reduce`, a scan of block totals, then `straight_bones`
        /// or a `fused_round` per depth; `elems` then holds one element
        /// per block, then one per `[`, not one per module).
        pub fused: u32 => "u32",
        /// Blocks of `SCAN_BLOCK` modules (fused).
        pub blocks: u32 => "u32",
        pub pad0: u32 => "u32",
    }
}

gpu_struct! {
    /// One system's turtle settings (`grm_turtle::TurtleConfig`) and where
    /// its symbols' [`TurtleSym`] records start (in words of the `tsyms`
    /// buffer).
    pub struct TurtleConfig {
        pub syms: u32 => "u32",
        pub angle: f32 => "f32",
        pub step: f32 => "f32",
        pub width: f32 => "f32",
        pub elasticity: f32 => "f32",
        pub tropism_x: f32 => "f32",
        pub tropism_y: f32 => "f32",
        pub tropism_z: f32 => "f32",
        pub has_tropism: u32 => "u32",
        pub pad0: u32 => "u32",
        pub pad1: u32 => "u32",
        pub pad2: u32 => "u32",
    }
}

gpu_struct! {
    /// A turtle transform or state: the affine frame (columns L, H, -U and
    /// the position), the width map `w -> wa * w + wb`, the last bone
    /// (module index) and the segment word (`SEG_*` bits and the segment's
    /// first module).
    pub struct TurtleElem {
        pub m: [f32; 12] => "array<f32, 12>",
        pub wa: f32 => "f32",
        pub wb: f32 => "f32",
        pub bone: u32 => "u32",
        pub seg: u32 => "u32",
    }
}

gpu_struct! {
    /// One bone, as `grm_turtle::Bone` has it (width at base and tip are
    /// equal there): base, tip, the unit left vector, the world width, the
    /// parent bone (`u32::MAX` for none) and the module index of its `F`.
    pub struct GpuBone {
        pub base_x: f32 => "f32",
        pub base_y: f32 => "f32",
        pub base_z: f32 => "f32",
        pub tip_x: f32 => "f32",
        pub tip_y: f32 => "f32",
        pub tip_z: f32 => "f32",
        pub left_x: f32 => "f32",
        pub left_y: f32 => "f32",
        pub left_z: f32 => "f32",
        pub width: f32 => "f32",
        pub parent: u32 => "u32",
        pub module_index: u32 => "u32",
    }
}

/// `TurtleElem::seg`: the element starts a segment.
pub const SEG_START: u32 = 1 << 31;
/// `TurtleElem::seg`: the state is cut off (`%`): nothing is drawn.
pub const SEG_DEAD: u32 = 1 << 30;
/// `TurtleElem::seg`: the segment's first module.
pub const SEG_INDEX: u32 = SEG_DEAD - 1;

/// Every shared struct's WGSL declaration, with Rust's size and offsets
/// (for the layout test).
pub fn structs() -> Vec<StructInfo> {
    fn one<T: GpuStruct>() -> StructInfo {
        StructInfo {
            name: T::NAME,
            wgsl: T::wgsl(),
            size: std::mem::size_of::<T>(),
            offsets: T::offsets(),
        }
    }
    vec![
        one::<ScanParams>(),
        one::<VmJob>(),
        one::<VmResult>(),
        one::<DeriveParams>(),
        one::<BatchParams>(),
        one::<ExpandParams>(),
        one::<ExpandJob>(),
        one::<ExpandTurtleParams>(),
        one::<BracketParams>(),
        one::<TurtleSym>(),
        one::<TurtleParams>(),
        one::<TurtleConfig>(),
        one::<TurtleElem>(),
        one::<GpuBone>(),
    ]
}

/// Every struct of the header: our own and the mirrored `grm-compile` records.
pub fn all_structs() -> Vec<StructInfo> {
    let mut v = structs();
    v.extend(mirrors().into_iter().map(|m| m.info));
    v
}

/// The WGSL header prepended to every kernel: constants and struct layouts
/// generated from their Rust definitions.
pub fn wgsl_header() -> String {
    let mut s = String::from("// ---- generated by grm-gpu from Rust definitions; do not edit\n");
    let consts: &[(&str, u32)] = &[
        ("WORKGROUP", WORKGROUP),
        ("WG_OFF_LEN", WORKGROUP + 1),
        ("SCAN_PER_THREAD", SCAN_PER_THREAD),
        ("SCAN_BLOCK", SCAN_BLOCK),
        ("STACK_SIZE", STACK_SIZE as u32),
        ("MAX_BIND_WORDS", MAX_BIND_WORDS),
        ("BRACKET_FAN", BRACKET_FAN),
        ("ERR_BAD_WEIGHT", ERR_BAD_WEIGHT),
        ("ERR_FAULT", ERR_FAULT),
        ("ERR_NON_FINITE", ERR_NON_FINITE),
        ("STATUS_WORDS", STATUS_WORDS),
        ("SYS_SHIFT", SYS_SHIFT),
        ("SYM_MASK", SYM_MASK),
        ("SEG_START", SEG_START),
        ("SEG_DEAD", SEG_DEAD),
        ("SEG_INDEX", SEG_INDEX),
        ("EXPAND_SLOT_WORDS", EXPAND_SLOT_WORDS),
        ("DIRECT_MAX_STEPS", DIRECT_MAX_STEPS),
        ("DIRECT_TURTLE_STACK", DIRECT_TURTLE_STACK),
        (
            "TURTLE_CONFIG_WORDS",
            (std::mem::size_of::<TurtleConfig>() / 4) as u32,
        ),
        (
            "TURTLE_SYM_WORDS",
            (std::mem::size_of::<TurtleSym>() / 4) as u32,
        ),
        ("NONE", t::NONE),
        ("PACKED_MAGIC", t::PACKED_MAGIC),
        ("SYM_PUSH", t::SYM_PUSH),
        ("SYM_POP", t::SYM_POP),
        ("SYM_IGNORED", t::SYM_IGNORED),
        ("SYM_TERMINAL", t::SYM_TERMINAL),
        ("GROUP_CONTEXT", t::GROUP_CONTEXT),
        ("GROUP_CONST_WEIGHTS", t::GROUP_CONST_WEIGHTS),
        ("GROUP_WRAPUP", t::GROUP_WRAPUP),
        ("ALT_NO_CODE", t::ALT_NO_CODE),
        ("CTX_SYMBOL", t::CTX_SYMBOL),
        ("CTX_PUSH", t::CTX_PUSH),
        ("CTX_POP", t::CTX_POP),
        ("PARAM_CONST", t::PARAM_CONST),
        ("PARAM_COPY", t::PARAM_COPY),
        ("PARAM_CODE", t::PARAM_CODE),
    ];
    for (name, v) in consts {
        s.push_str(&format!("const {name}: u32 = {v}u;\n"));
    }
    // Record sizes in words.
    for m in mirrors() {
        s.push_str(&format!(
            "const {}_WORDS: u32 = {}u;\n",
            screaming(m.info.name),
            m.info.size / 4
        ));
    }
    for op in crate::interp::TurtleOp::ALL {
        s.push_str(&format!(
            "const TOP_{}: u32 = {}u;\n",
            screaming(&format!("{op:?}")),
            *op as u32
        ));
    }
    for op in Op::ALL {
        s.push_str(&format!(
            "const {}: u32 = {}u;\n",
            op_const_name(*op),
            *op as u32
        ));
    }
    // The float constants of the VM, with the CPU VM's exact values.
    let fconsts: &[(&str, f32)] = &[
        ("DEG_TO_RAD", std::f32::consts::PI / 180.0),
        ("RAD_TO_DEG", 1.0f32.to_degrees()),
        ("LOG10_2", std::f32::consts::LOG10_2),
        ("LOG10_E", std::f32::consts::LOG10_E),
        ("LOG2_E", std::f32::consts::LOG2_E),
        ("TAU", std::f32::consts::TAU),
        ("SHRINK", grm_turtle::SHRINK),
        ("WEIGHT_SCALE", t::WEIGHT_SCALE),
    ];
    for (name, v) in fconsts {
        s.push_str(&format!("const {name}: f32 = {};\n", f32_lit(*v)));
    }
    for st in structs() {
        s.push_str(&st.wgsl);
    }
    for m in mirrors() {
        s.push_str(&m.info.wgsl);
    }
    s
}
