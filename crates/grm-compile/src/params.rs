//! Meta-parameter values from `NAME=VALUE` overrides, as `grmc` takes them
//! on the command line (`--param`), ready for [`crate::compile`].

use grm_sema::{Program, Ty, Value};

/// The program's default meta-parameter values with `NAME=VALUE`
/// overrides applied: a number (inside the parameter's range, if it has
/// one), `true`/`false`, or `x,y,z` for a vec3. `Err` says which override
/// is wrong and why.
pub fn param_values(program: &Program, overrides: &[String]) -> Result<Vec<Value>, String> {
    let mut values = program.default_params();
    let mut given: Vec<(&str, &str)> = Vec::new();
    for o in overrides {
        let Some((name, text)) = o.split_once('=') else {
            return Err(format!("`--param {o}`: write it as NAME=VALUE"));
        };
        let (name, text) = (name.trim(), text.trim());
        // Two values for one parameter: a mistake to point out, not one
        // to settle by taking the last.
        if let Some((_, first)) = given.iter().find(|(n, _)| *n == name) {
            return Err(format!(
                "`--param {name}` is given twice (`{first}` and `{text}`)"
            ));
        }
        given.push((name, text));
        let Some(id) = program.param_by_name(name) else {
            let known: Vec<&str> = program.params.iter().map(|p| p.name.as_str()).collect();
            return Err(if known.is_empty() {
                format!("unknown meta-parameter `{name}`: the file declares none")
            } else {
                format!(
                    "unknown meta-parameter `{name}`; the file declares: {}",
                    known.join(", ")
                )
            });
        };
        let p = &program.params[id.index()];
        let number = |s: &str| -> Result<f64, String> {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`--param {name}={text}`: `{s}` is not a finite number"))
        };
        let v = match p.ty {
            Ty::Float => {
                let x = number(text)?;
                if let Some((lo, hi)) = p.range
                    && !(lo..=hi).contains(&x)
                {
                    return Err(format!(
                        "`--param {name}={text}`: outside its range {lo} .. {hi}"
                    ));
                }
                Value::Float(x)
            }
            Ty::Bool => match text {
                "true" => Value::Bool(true),
                "false" => Value::Bool(false),
                _ => return Err(format!("`--param {name}={text}`: expected true or false")),
            },
            Ty::Vec3 => {
                let parts: Vec<&str> = text.split(',').collect();
                if parts.len() != 3 {
                    return Err(format!("`--param {name}={text}`: expected x,y,z"));
                }
                Value::Vec3([number(parts[0])?, number(parts[1])?, number(parts[2])?])
            }
            other => return Err(format!("`{name}` is a `{other}`; it cannot be overridden")),
        };
        values[id.index()] = v;
    }
    Ok(values)
}
