//! Sweeps in parts: shards merged against one run, bit for bit; every defect of a set of
//! shards a typed error; results independent of the thread count.

use crate::base::cancel::Cancel;
use crate::grid::Cells;
use crate::mc::Shard;
use crate::model::{parse_model, Model};
use crate::solve::MethodName;

use super::{merge_sweep_shards, ShardDifference, Sweep, SweepShard, SweepShardError, SweepSpec};

/// A linear oscillator: EPC is exact at every degree, the grid solver close.
fn linear() -> Model {
    parse_model(
        "model linear
param c = 0.2, k = 1, S = 1
state z, v
drift z: v
drift v: -c*v - k*z
noise xi: intensity S
diffusion v: xi
observe a = abs(z)
",
        None,
    )
    .unwrap()
}

fn shards(sweep: &Sweep, count: u64) -> Vec<(String, SweepShard)> {
    (0..count)
        .map(|k| {
            let s = sweep
                .run_shard(Shard::new(k, count).unwrap(), &Cancel::new())
                .unwrap();
            (s.file_name(), s)
        })
        .collect()
}

/// `sweep.json` text without its provenance and its timings (`wall_ms`, the grid's `…_ms`:
/// the only lines that differ between runs), keys in order; the provenance is checked to be
/// there, with the model.
fn untimed(json: &str) -> String {
    let mut value: serde_json::Value = serde_json::from_str(json).unwrap();
    let provenance = value.as_object_mut().unwrap().remove("provenance").unwrap();
    assert!(provenance["created"].as_str().unwrap().ends_with('Z'));
    assert_eq!(provenance["model"]["name"], value["model"]);
    let json = serde_json::to_string_pretty(&value).unwrap();
    json.lines()
        .filter(|l| {
            let key = l.trim_start().split(':').next().unwrap_or("");
            !(key.starts_with('"') && key.ends_with("_ms\""))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The JSON `SweepResult::write` writes (serde_json, pretty, with a final newline).
fn json_of(result: &super::SweepResult) -> String {
    let mut text = serde_json::to_string_pretty(result).unwrap();
    text.push('\n');
    text
}

#[test]
fn shards_merge_to_the_text_of_one_run_in_any_order() {
    let model = linear();
    // Two swept parameters, a fixed one, and a point whose intensity is negative (a bind
    // failure), first, so that the tail thresholds' reference point is the second point.
    let spec = SweepSpec::parse(&[
        "S=-1,1,2".to_string(),
        "c=0.2:0.4:3".to_string(),
        "k=1.5".to_string(),
    ])
    .unwrap();
    let sweep = Sweep::new(&model, &spec).degree(4);
    let one = sweep.run();
    assert_eq!(one.threshold_point, Some(1));
    for count in [1, 2, 4, 9] {
        let mut parts = shards(&sweep, count);
        parts.reverse();
        let merged = merge_sweep_shards(&parts).unwrap();
        assert_eq!(merged.csv(), one.to_csv(), "{count} shards");
        assert_eq!(untimed(merged.json()), untimed(&json_of(&one)), "{count}");
        assert_eq!(merged.points(), 9);
        assert_eq!(merged.converged(), one.converged());
    }
}

#[test]
fn a_shard_file_merges_after_a_trip_through_json() {
    let model = linear();
    let spec = SweepSpec::parse(&["c=0.1:0.5:5".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec).degree(2);
    let parts: Vec<(String, SweepShard)> = shards(&sweep, 2)
        .into_iter()
        .map(|(n, s)| {
            (
                n,
                serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap(),
            )
        })
        .collect();
    let merged = merge_sweep_shards(&parts).unwrap();
    assert_eq!(merged.csv(), sweep.run().to_csv());
}

/// A merge states the parts' model and the threads they ran with (not the merging
/// process's), first in its file.
#[test]
fn a_merge_states_the_threads_and_the_model_of_its_parts() {
    let model = linear();
    let spec = SweepSpec::parse(&["c=0.1:0.5:5".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec).degree(2);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let parts = one.install(|| shards(&sweep, 2));
    let part = parts[0].1.provenance.as_ref().unwrap();
    assert_eq!(part["threads"], 1, "{part}");
    let merged = merge_sweep_shards(&parts).unwrap();
    assert!(merged.json().starts_with("{\n  \"provenance\": {\n"));
    let value: serde_json::Value = serde_json::from_str(merged.json()).unwrap();
    let provenance = &value["provenance"];
    assert_eq!(provenance["threads"], 1, "{provenance}");
    assert_eq!(provenance["model"], part["model"]);
    assert!(provenance["model"]["text"]
        .as_str()
        .unwrap()
        .contains("observe a"));
}

#[test]
fn grid_sweeps_shard_too() {
    let model = linear();
    let spec = SweepSpec::parse(&["c=0.3,0.5,0.7".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec)
        .methods("grid,epc".parse().unwrap())
        .degree(2)
        .cells(Cells([24, 48]));
    let one = sweep.run();
    assert_eq!(one.converged_by(MethodName::Grid), 3);
    let merged = merge_sweep_shards(&shards(&sweep, 3)).unwrap();
    assert_eq!(merged.csv(), one.to_csv());
    assert_eq!(untimed(merged.json()), untimed(&json_of(&one)));
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let model = linear();
    let spec = SweepSpec::parse(&["c=0.1:0.6:6".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec).degree(4);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let alone = pool.install(|| sweep.run().to_csv());
    assert_eq!(alone, sweep.run().to_csv());
}

#[test]
fn defective_sets_of_shards_are_typed_errors_naming_the_file() {
    let model = linear();
    let spec = SweepSpec::parse(&["c=0.1:0.5:5".to_string()]).unwrap();
    let sweep = Sweep::new(&model, &spec).degree(2);
    let parts = shards(&sweep, 3);

    assert_eq!(
        merge_sweep_shards::<String>(&[]).unwrap_err(),
        SweepShardError::NoShards
    );
    let err = merge_sweep_shards(&parts[..2]).unwrap_err();
    assert!(
        matches!(err, SweepShardError::Missing { ref missing, count: 3, .. } if missing == &[3])
    );

    let mut twice = parts.clone();
    twice.push(("copy.json".to_string(), parts[1].1.clone()));
    let err = merge_sweep_shards(&twice).unwrap_err();
    assert!(
        matches!(err, SweepShardError::Duplicated { ref file, index: 2, .. } if file == "copy.json")
    );

    // Another degree, another parameter range, another split: another sweep.
    let other_degree = shards(&Sweep::new(&model, &spec).degree(4), 3);
    let spec2 = SweepSpec::parse(&["c=0.1:0.6:5".to_string()]).unwrap();
    let other_points = shards(&Sweep::new(&model, &spec2).degree(2), 3);
    let other_split = shards(&sweep, 5);
    for (stranger, what) in [
        (&other_degree[2], ShardDifference::Degree),
        (&other_points[2], ShardDifference::Points),
        (&other_split[4], ShardDifference::Split),
    ] {
        let mut mixed = parts[..2].to_vec();
        mixed.push(("stranger.json".to_string(), stranger.1.clone()));
        let err = merge_sweep_shards(&mixed).unwrap_err();
        assert!(
            matches!(err, SweepShardError::Mismatch { ref file, what: w, .. } if file == "stranger.json" && w == what),
            "{err:?}"
        );
    }

    // A shard claiming another index than its points.
    let mut liar = parts.clone();
    liar[0].1.shard.index = 1;
    liar[0].0 = "liar.json".to_string();
    let err = merge_sweep_shards(&liar).unwrap_err();
    assert!(
        matches!(err, SweepShardError::Points { ref file, index: 2, .. } if file == "liar.json")
    );

    // A shard index beyond its split.
    let mut beyond = parts.clone();
    beyond[2].1.shard.index = 7;
    let err = merge_sweep_shards(&beyond).unwrap_err();
    assert!(matches!(
        err,
        SweepShardError::Points {
            index: 8,
            count: 3,
            ..
        }
    ));
}

#[test]
fn a_file_of_another_kind_is_not_a_sweep_shard() {
    let model = linear();
    let spec = SweepSpec::parse(&["c=0.1,0.2".to_string()]).unwrap();
    let parts = shards(&Sweep::new(&model, &spec).degree(2), 1);
    let mut value = serde_json::to_value(&parts[0].1).unwrap();
    value["kind"] = "something else".into();
    let forged: SweepShard = serde_json::from_value(value).unwrap();
    let err = merge_sweep_shards(&[("forged.json", forged)]).unwrap_err();
    assert_eq!(
        err,
        SweepShardError::NotAShard {
            file: "forged.json".to_string()
        }
    );
}
