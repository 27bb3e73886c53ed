//! Which plugins to load with which arguments: from the command line
//! (`--plugin PATH --plugin-arg KEY=VALUE ...`) or a TOML file.

use std::path::{Path, PathBuf};

/// One plugin to load: its library and its `key=value` arguments in order.
#[derive(Clone, Debug, PartialEq)]
pub struct PluginSpec {
    pub path: PathBuf,
    pub args: Vec<(String, String)>,
}

/// Groups command-line arguments: each `--plugin-arg KEY=VALUE` belongs to
/// the nearest `--plugin PATH` before it. Both lists carry the position of
/// each occurrence on the command line (clap's `indices_of`).
pub fn specs_from_command_line(
    plugins: &[(usize, PathBuf)],
    args: &[(usize, String)],
) -> Result<Vec<PluginSpec>, String> {
    let mut specs: Vec<(usize, PluginSpec)> = plugins
        .iter()
        .map(|(i, p)| {
            (
                *i,
                PluginSpec {
                    path: p.clone(),
                    args: Vec::new(),
                },
            )
        })
        .collect();
    specs.sort_by_key(|s| s.0);
    for (i, a) in args {
        let (k, v) = split_arg(a)?;
        match specs.iter_mut().rev().find(|s| s.0 < *i) {
            Some(s) => s.1.args.push((k, v)),
            None => {
                return Err(format!(
                    "--plugin-arg {a}: comes before any --plugin (write --plugin PATH first, \
                     then its arguments)"
                ))
            }
        }
    }
    Ok(specs.into_iter().map(|s| s.1).collect())
}

fn split_arg(a: &str) -> Result<(String, String), String> {
    match a.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
        _ => Err(format!("--plugin-arg '{a}': expected KEY=VALUE")),
    }
}

/// Reads a plugin configuration file:
///
/// ```toml
/// [[plugin]]
/// path = "libbubblemesh_plugin_curvature.so"   # relative to this file
/// args = { eps = 0.001, d_max = 0.2 }
///
/// [[plugin]]
/// path = "/opt/plugins/libview.so"
/// [plugin.args]
/// viewpoint = [0, 0, 5]     # arrays of numbers become "0,0,5"
/// factor = 0.05
/// ```
///
/// Values may be strings, numbers, booleans or arrays of numbers; each is
/// passed to the plugin as text.
pub fn read_config(path: &Path) -> Result<Vec<PluginSpec>, String> {
    let where_ = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("{where_}: {e}"))?;
    let doc: toml::Table = text.parse().map_err(|e| format!("{where_}: {e}"))?;
    let base = path.parent().unwrap_or(Path::new(""));
    for k in doc.keys() {
        if k != "plugin" {
            return Err(format!(
                "{where_}: unknown key '{k}' (expected [[plugin]] tables)"
            ));
        }
    }
    let Some(list) = doc.get("plugin") else {
        return Err(format!("{where_}: no [[plugin]] table"));
    };
    let list = list
        .as_array()
        .ok_or_else(|| format!("{where_}: 'plugin' must be an array of tables ([[plugin]])"))?;
    let mut out = Vec::new();
    for (n, item) in list.iter().enumerate() {
        let at = format!("{where_}: plugin {}", n + 1);
        let t = item
            .as_table()
            .ok_or_else(|| format!("{at}: expected a table"))?;
        for k in t.keys() {
            if k != "path" && k != "args" {
                return Err(format!("{at}: unknown key '{k}' (expected path, args)"));
            }
        }
        let p = t
            .get("path")
            .and_then(|v| v.as_str())
            .ok_or_else(|| format!("{at}: 'path' (a string) is missing"))?;
        let p = Path::new(p);
        let full = if p.is_absolute() {
            p.to_path_buf()
        } else {
            base.join(p)
        };
        let mut args = Vec::new();
        if let Some(a) = t.get("args") {
            let a = a
                .as_table()
                .ok_or_else(|| format!("{at}: 'args' must be a table of key = value"))?;
            for (k, v) in a {
                args.push((
                    k.clone(),
                    value_text(v).map_err(|e| format!("{at}: {k}: {e}"))?,
                ));
            }
        }
        out.push(PluginSpec { path: full, args });
    }
    Ok(out)
}

fn value_text(v: &toml::Value) -> Result<String, String> {
    use toml::Value::*;
    Ok(match v {
        String(s) => s.clone(),
        Integer(i) => i.to_string(),
        Float(f) => f.to_string(),
        Boolean(b) => b.to_string(),
        Array(a) => a
            .iter()
            .map(|x| match x {
                Integer(i) => Ok(i.to_string()),
                Float(f) => Ok(f.to_string()),
                _ => Err("arrays may hold numbers only".to_string()),
            })
            .collect::<Result<Vec<_>, _>>()?
            .join(","),
        _ => return Err("expected a string, number, boolean or array of numbers".into()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn args_follow_their_plugin() {
        let specs = specs_from_command_line(
            &[(2, "a.so".into()), (8, "b.so".into())],
            &[(4, "x=1".into()), (6, "y=2=3".into()), (10, "z=".into())],
        )
        .unwrap();
        assert_eq!(
            specs[0].args,
            vec![("x".into(), "1".into()), ("y".into(), "2=3".into())]
        );
        assert_eq!(specs[1].args, vec![("z".into(), "".into())]);
        let e = specs_from_command_line(&[(5, "a.so".into())], &[(3, "x=1".into())]).unwrap_err();
        assert!(e.contains("before any --plugin"), "{e}");
        let e = specs_from_command_line(&[(1, "a.so".into())], &[(3, "x".into())]).unwrap_err();
        assert!(e.contains("KEY=VALUE"), "{e}");
    }

    #[test]
    fn config_file_is_read_relative_to_itself() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("p.toml");
        std::fs::write(
            &f,
            "[[plugin]]\npath = \"lib/a.so\"\nargs = { eps = 0.5, v = [1, 2.5, 3], name = \"q\" }\n\
             [[plugin]]\npath = \"/abs/b.so\"\n",
        )
        .unwrap();
        let s = read_config(&f).unwrap();
        assert_eq!(s[0].path, dir.path().join("lib/a.so"));
        assert!(s[0].args.contains(&("v".into(), "1,2.5,3".into())));
        assert!(s[0].args.contains(&("eps".into(), "0.5".into())));
        assert_eq!(s[1].path, PathBuf::from("/abs/b.so"));
        std::fs::write(&f, "[[plugin]]\npth = \"x\"\n").unwrap();
        let e = read_config(&f).unwrap_err();
        assert!(e.contains("p.toml") && e.contains("'pth'"), "{e}");
    }
}
