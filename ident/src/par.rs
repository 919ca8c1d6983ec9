//! Independent runs over a list, spread over the machine's cores: each worker takes every
//! `workers`-th item, so the results come back in the items' order and each is exactly what
//! the run alone gives.

/// `run` of each of `items`, on up to as many threads as the machine has cores (one: on the
/// caller's). A run that panics panics the caller, as it would have run there.
pub fn map<T: Sync, R: Send>(items: &[T], run: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let workers = std::thread::available_parallelism()
        .map_or(1, |t| t.get())
        .min(items.len());
    if workers <= 1 {
        return items.iter().map(run).collect();
    }
    let run = &run;
    let mut out: Vec<Option<R>> = std::iter::repeat_with(|| None).take(items.len()).collect();
    std::thread::scope(|scope| {
        let runs: Vec<_> = (0..workers)
            .map(|w| {
                scope.spawn(move || {
                    (w..items.len())
                        .step_by(workers)
                        .map(|i| (i, run(&items[i])))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for r in runs {
            let done = r.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
            for (i, v) in done {
                out[i] = Some(v);
            }
        }
    });
    // Every item was run by exactly one worker.
    out.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn results_come_back_in_the_items_order() {
        let items: Vec<u64> = (0..37).collect();
        let out = super::map(&items, |x| x * x + 1);
        let want: Vec<u64> = items.iter().map(|x| x * x + 1).collect();
        assert_eq!(out, want);
        assert!(super::map(&[] as &[u64], |x| *x).is_empty());
    }

    #[test]
    #[should_panic(expected = "item 5")]
    fn a_run_that_panics_panics_the_caller() {
        let items: Vec<u64> = (0..8).collect();
        super::map(&items, |x| assert!(*x != 5, "item {x}"));
    }
}
