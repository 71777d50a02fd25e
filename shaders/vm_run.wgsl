// The bytecode interpreter's dispatch loop (vm.wgsl's `vm_run`): one
// instruction per turn, each op as grm_compile::op defines it.
fn vm_run(entry: u32, d: Draws) -> u32 {
    var pc = entry;
    var sp = 0u;
    loop {
        if (pc >= TAB.code_count) {
            return VM_FAULT;
        }
        let word = vm_code(pc);
        pc = pc + 1u;
        let op = word & 0xffu;
        let a = word >> 8u;
        switch op {
            case OP_RET: {
                return sp;
            }
            case OP_CONST: {
                vm_st[sp] = vm_const(a);
                sp = sp + 1u;
            }
            case OP_CONST3: {
                vm_st[sp] = vm_const(a);
                vm_st[sp + 1u] = vm_const(a + 1u);
                vm_st[sp + 2u] = vm_const(a + 2u);
                sp = sp + 3u;
            }
            case OP_LOAD: {
                vm_st[sp] = vm_bind[a];
                sp = sp + 1u;
            }
            case OP_LOAD3: {
                vm_st[sp] = vm_bind[a];
                vm_st[sp + 1u] = vm_bind[a + 1u];
                vm_st[sp + 2u] = vm_bind[a + 2u];
                sp = sp + 3u;
            }
            case OP_SPLAT: {
                let x = vm_st[sp - 1u];
                vm_st[sp] = x;
                vm_st[sp + 1u] = x;
                sp = sp + 2u;
            }
            case OP_PICK: {
                let base = sp - 3u;
                vm_st[base] = vm_st[base + a];
                sp = base + 1u;
            }
            case OP_NEG, OP_ABS, OP_FLOOR, OP_CEIL, OP_ROUND, OP_FRACT, OP_SIGN: {
                for (var k = sp - a; k < sp; k = k + 1u) {
                    vm_st[k] = unary(op, vm_st[k]);
                }
            }
            case OP_NOT, OP_SIN, OP_COS, OP_TAN, OP_ASIN, OP_ACOS, OP_ATAN, OP_SQRT, OP_EXP, OP_LN, OP_LOG10: {
                vm_st[sp - 1u] = unary(op, vm_st[sp - 1u]);
            }
            case OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_REM, OP_MIN, OP_MAX, OP_STEP: {
                let base = sp - 2u * a;
                for (var k = 0u; k < a; k = k + 1u) {
                    vm_st[base + k] = binary(op, vm_st[base + k], vm_st[base + a + k]);
                }
                sp = base + a;
            }
            case OP_EQ, OP_NE: {
                let base = sp - 2u * a;
                var eq = true;
                for (var k = 0u; k < a; k = k + 1u) {
                    eq = eq && (vm_st[base + k] == vm_st[base + a + k]);
                }
                vm_st[base] = b2f(eq == (op == OP_EQ));
                sp = base + 1u;
            }
            case OP_LT, OP_LE, OP_GT, OP_GE, OP_AND, OP_OR, OP_ATAN2, OP_POW: {
                let base = sp - 2u;
                vm_st[base] = binary(op, vm_st[base], vm_st[base + 1u]);
                sp = base + 1u;
            }
            case OP_SELECT: {
                let base = sp - (1u + 2u * a);
                var src = base + 1u + a;
                if (truthy(vm_st[base])) {
                    src = base + 1u;
                }
                for (var k = 0u; k < a; k = k + 1u) {
                    vm_st[base + k] = vm_st[src + k];
                }
                sp = base + a;
            }
            case OP_CLAMP, OP_MIX, OP_SMOOTHSTEP: {
                let base = sp - 3u * a;
                for (var k = 0u; k < a; k = k + 1u) {
                    vm_st[base + k] = ternary(op, vm_st[base + k], vm_st[base + a + k], vm_st[base + 2u * a + k]);
                }
                sp = base + a;
            }
            case OP_DOT, OP_DISTANCE, OP_CROSS: {
                let base = sp - 6u;
                let u = vec3<f32>(vm_st[base], vm_st[base + 1u], vm_st[base + 2u]);
                let v = vec3<f32>(vm_st[base + 3u], vm_st[base + 4u], vm_st[base + 5u]);
                if (op == OP_DOT) {
                    vm_st[base] = u.x * v.x + u.y * v.y + u.z * v.z;
                    sp = base + 1u;
                } else if (op == OP_DISTANCE) {
                    let e = u - v;
                    vm_st[base] = sqrt(e.x * e.x + e.y * e.y + e.z * e.z);
                    sp = base + 1u;
                } else {
                    vm_st[base] = u.y * v.z - u.z * v.y;
                    vm_st[base + 1u] = u.z * v.x - u.x * v.z;
                    vm_st[base + 2u] = u.x * v.y - u.y * v.x;
                    sp = base + 3u;
                }
            }
            case OP_LENGTH, OP_NORMALIZE: {
                let base = sp - 3u;
                let x = vm_st[base];
                let y = vm_st[base + 1u];
                let z = vm_st[base + 2u];
                let l = sqrt(x * x + y * y + z * z);
                if (op == OP_LENGTH) {
                    vm_st[base] = l;
                    sp = base + 1u;
                } else if (l > 0.0) {
                    vm_st[base] = x / l;
                    vm_st[base + 1u] = y / l;
                    vm_st[base + 2u] = z / l;
                } else {
                    vm_st[base] = 0.0;
                    vm_st[base + 1u] = 0.0;
                    vm_st[base + 2u] = 0.0;
                }
            }
            case OP_SPLINE: {
                let n = a & 0xffffu;
                let w = a >> 16u;
                let base = sp - (1u + n * w);
                vm_spline(base, n, w);
                sp = base + w;
            }
            case OP_RAND_UNIFORM: {
                let base = sp - 2u;
                vm_st[base] = vm_rand_uniform(vm_st[base], vm_st[base + 1u], rng_uniform(d, a));
                sp = base + 1u;
            }
            case OP_RAND_NORMAL: {
                let base = sp - 2u;
                let u1 = rng_uniform(d, a);
                let u2 = rng_uniform(d, a + 1u);
                let z = sqrt(-2.0 * fln(1.0 - u1)) * cos(TAU * u2);
                vm_st[base] = vm_st[base] + vm_st[base + 1u] * z;
                sp = base + 1u;
            }
            case OP_RAND_INT: {
                let base = sp - 2u;
                vm_st[base] = vm_rand_int(vm_st[base], vm_st[base + 1u], rng_uniform(d, a));
                sp = base + 1u;
            }
            case OP_RAND_CHANCE: {
                vm_st[sp - 1u] = b2f(rng_uniform(d, a) < vm_st[sp - 1u]);
            }
            case OP_RAND_CHOOSE: {
                if (pc >= TAB.code_count) {
                    return VM_FAULT;
                }
                let draw = vm_code(pc);
                pc = pc + 1u;
                let n = a & 0xffffu;
                let w = a >> 16u;
                let base = sp - n * (w + 1u);
                vm_choose(base, n, w, rng_uniform(d, draw));
                sp = base + w;
            }
            default: {
                return VM_FAULT;
            }
        }
    }
    return VM_FAULT;
}
