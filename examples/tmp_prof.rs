use aem_electrolyser::model::*;
#[path = "../bench/model_step.rs"] #[allow(dead_code)] mod b;
fn main(){
    let d = CurrentDynamics::new(&Parameters::default());
    let w = b::wind_like_setpoints(86400, 42);
    let mut f = StepFactors::default();
    let mut acc = 0.0;
    let t = std::time::Instant::now();
    for _ in 0..20 {
        let mut s = d.steady_state(80.0);
        for u in &w { let u = u.clamp(60.0, 100.0); acc += d.advance(&mut s, u, 1.0, &mut f).charge; }
    }
    println!("{:.1} ns/step {}", t.elapsed().as_secs_f64()*1e9/(20.0*86400.0), acc);
}
