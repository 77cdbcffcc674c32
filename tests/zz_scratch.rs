#[test]
fn scratch() {
    let m = fpsolve::model::load_model("models/vibro_impact_duffing.sde".as_ref()).unwrap();
    let b = m.bind(&[]).unwrap();
    let sol = fpsolve::solve(&b, fpsolve::Method::EpcImpact { degree: 4 }).unwrap();
    println!(
        "states {:?}",
        sol.quantities()
            .iter()
            .map(|q| (&q.name, &q.map))
            .collect::<Vec<_>>()
    );
    println!("pdf y {:?}", sol.pdf("y", &[0.0, 1e-12, 1e-3]).unwrap());
    println!("extent {:?}", sol.joint().extent());
}
