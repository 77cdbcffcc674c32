//! `fpsolve merge` refuses shard files that were edited (consistently enough to pass every
//! invariant a shard's numbers must satisfy) or renamed to another index: each carries
//! digests of its settings and statistics, checked by merge. Before the digests, all four
//! repros below merged with exit 0 into wrong (or mislabelled) numbers.

mod common;

use common::{fpsolve, scratch};
use serde_json::{json, Value};
use std::path::Path;

const MODEL: &str = "models/vibro_impact_duffing.sde";

/// Two honest shards of one run in `dir`.
fn write_shards(dir: &Path) {
    for k in ["1/2", "2/2"] {
        let o = fpsolve(&[
            "simulate",
            MODEL,
            "--samples",
            "2e4",
            "--trajectories",
            "256",
            "--shard",
            k,
            "--quiet",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
}

fn edit_json(path: &Path, edit: impl FnOnce(&mut Value)) {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(path, serde_json::to_string(&v).unwrap()).unwrap();
}

fn num(v: &Value) -> f64 {
    v.as_str().unwrap().parse().unwrap()
}

#[test]
fn edited_and_renamed_shards_are_refused_naming_the_file() {
    let root = scratch("shard-digest");
    let honest = root.join("honest");
    write_shards(&honest);
    let one = |d: &Path| d.join("shard_1_of_2.json");
    let two = |d: &Path| d.join("shard_2_of_2.json");
    type Corrupt = fn(&Path);
    let cases: [(&str, Corrupt, &str); 5] = [
        (
            "a count moved to the next bin",
            |d| {
                edit_json(&d.join("shard_2_of_2.json"), |v| {
                    let c = v["batches"][0]["quantities"][0]["counts"]
                        .as_array_mut()
                        .unwrap();
                    let n = |x: &Value| x.as_u64().unwrap();
                    let j = (0..c.len() - 1)
                        .find(|&j| n(&c[j]) > 1 && n(&c[j + 1]) > 0)
                        .unwrap();
                    c[j] = json!(n(&c[j]) - 1);
                    c[j + 1] = json!(n(&c[j + 1]) + 1);
                })
            },
            "shard_2_of_2.json",
        ),
        (
            "an extreme moved inside its range",
            |d| {
                edit_json(&d.join("shard_2_of_2.json"), |v| {
                    let q = &mut v["batches"][0]["quantities"][0];
                    q["max"] = json!(format!("{:?}", num(&q["max"]) * (1.0 - 1e-12)));
                })
            },
            "shard_2_of_2.json",
        ),
        (
            "a garbage barrier map in every shard",
            |d| {
                for f in ["shard_1_of_2.json", "shard_2_of_2.json"] {
                    edit_json(&d.join(f), |v| {
                        v["settings"]["barriers"][0]["map"] = json!("garbage");
                    });
                }
            },
            "shard_1_of_2.json",
        ),
        (
            "two shards' names swapped",
            |d| {
                let tmp = d.join("swap");
                std::fs::rename(d.join("shard_1_of_2.json"), &tmp).unwrap();
                std::fs::rename(d.join("shard_2_of_2.json"), d.join("shard_1_of_2.json")).unwrap();
                std::fs::rename(&tmp, d.join("shard_2_of_2.json")).unwrap();
            },
            "shard_1_of_2.json",
        ),
        (
            "files of an older fpsolve, without digests",
            |d| {
                for f in ["shard_1_of_2.json", "shard_2_of_2.json"] {
                    edit_json(&d.join(f), |v| {
                        v.as_object_mut().unwrap().remove("digest");
                    });
                }
            },
            "shard_1_of_2.json",
        ),
    ];
    for (k, (what, corrupt, file)) in cases.into_iter().enumerate() {
        let dir = root.join(format!("case{k}"));
        std::fs::create_dir_all(&dir).unwrap();
        for f in [one(&honest), two(&honest)] {
            std::fs::copy(&f, dir.join(f.file_name().unwrap())).unwrap();
        }
        corrupt(&dir);
        let out = root.join(format!("merged{k}"));
        let o = fpsolve(&[
            "merge",
            dir.to_str().unwrap(),
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        eprintln!("{what}: {err}");
        assert_eq!(o.status.code(), Some(2), "{what}: {err}");
        assert!(
            err.contains(&dir.join(file).display().to_string()),
            "{what}: {err}"
        );
        assert!(!out.exists(), "{what}: something was written");
    }
    // The honest shards still merge.
    let out = root.join("merged");
    let o = fpsolve(&[
        "merge",
        honest.to_str().unwrap(),
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&root);
}
