//! The lab's one worker pool: independent work (Jacobian columns, candidates, windows,
//! sessions) runs on rayon's work-stealing pool, nested maps included, and always comes
//! back in index order, so a result is bit-identical for any number of threads (each item
//! is computed alone; nothing is summed across items in the pool).
//!
//! `threads` = 1 runs serially on the caller's thread. Otherwise the work runs on a pool
//! of that many threads (one per count, built once and kept), or on the pool the caller
//! already runs in. The caller's [`crate::progress`] is carried into every worker.

use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

/// Worker threads by default: every core this process may use.
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The pools built so far, by worker count.
type Pools = Mutex<Vec<(usize, Arc<rayon::ThreadPool>)>>;

/// The pool of `threads` workers (built on first use; `None` if it cannot be built).
fn pool(threads: usize) -> Option<Arc<rayon::ThreadPool>> {
    static POOLS: OnceLock<Pools> = OnceLock::new();
    let mut pools = POOLS.get_or_init(|| Mutex::new(Vec::new())).lock().ok()?;
    if let Some((_, p)) = pools.iter().find(|(n, _)| *n == threads) {
        return Some(Arc::clone(p));
    }
    let p = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("lab-worker-{i}"))
            .build()
            .ok()?,
    );
    pools.push((threads, Arc::clone(&p)));
    Some(p)
}

/// Runs `work` on the pool of `threads` workers, or right here when already a worker
/// (nested work shares the pool); `None` when no pool can be built.
fn in_pool<T: Send>(threads: usize, work: impl FnOnce() -> T + Send) -> Result<T, ()> {
    if rayon::current_thread_index().is_some() {
        return Ok(work());
    }
    match pool(threads) {
        Some(p) => Ok(p.install(work)),
        None => Err(()),
    }
}

/// `f(0)…f(n−1)` on up to `threads` workers, in index order.
pub(crate) fn par_map<T, F>(n: usize, threads: usize, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync + Send,
{
    if threads <= 1 || n <= 1 {
        return (0..n).map(f).collect();
    }
    let progress = crate::progress::current();
    let work = || -> Vec<T> {
        (0..n)
            .into_par_iter()
            .map(|i| {
                let _current = crate::progress::enter(progress.clone());
                f(i)
            })
            .collect()
    };
    in_pool(threads, work).unwrap_or_else(|()| (0..n).map(&f).collect())
}

/// `f(item)` for every item on up to `threads` workers, in the items' order.
pub(crate) fn par_map_items<I, T, F>(items: &[I], threads: usize, f: F) -> Vec<T>
where
    I: Sync,
    T: Send,
    F: Fn(&I) -> T + Sync + Send,
{
    if threads <= 1 || items.len() <= 1 {
        return items.iter().map(f).collect();
    }
    let progress = crate::progress::current();
    let work = || -> Vec<T> {
        items
            .par_iter()
            .map(|item| {
                let _current = crate::progress::enter(progress.clone());
                f(item)
            })
            .collect()
    };
    in_pool(threads, work).unwrap_or_else(|()| items.iter().map(&f).collect())
}

/// `f(i, chunk_i)` for each `chunk`-long piece of `data` (the last may be shorter), on up
/// to `threads` workers: in-place work on disjoint parts of one buffer (a Jacobian's
/// columns).
pub(crate) fn par_chunks_mut<T, F>(data: &mut [T], chunk: usize, threads: usize, f: F)
where
    T: Send,
    F: Fn(usize, &mut [T]) + Sync + Send,
{
    let chunk = chunk.max(1);
    if threads <= 1 || data.len() <= chunk {
        data.chunks_mut(chunk)
            .enumerate()
            .for_each(|(i, c)| f(i, c));
        return;
    }
    let progress = crate::progress::current();
    let work = |data: &mut [T]| {
        data.par_chunks_mut(chunk).enumerate().for_each(|(i, c)| {
            let _current = crate::progress::enter(progress.clone());
            f(i, c)
        })
    };
    if in_pool(threads, || work(&mut *data)).is_err() {
        data.chunks_mut(chunk)
            .enumerate()
            .for_each(|(i, c)| f(i, c));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_is_kept_for_any_thread_count_and_nesting() {
        let serial: Vec<f64> = (0..200).map(|i| (i as f64).sqrt().sin()).collect();
        for threads in [1, 2, 4] {
            let out = par_map(200, threads, |i| (i as f64).sqrt().sin());
            assert_eq!(out, serial, "threads {threads}");
            let nested = par_map(10, threads, |i| par_map(20, threads, |k| i * 100 + k));
            for (i, row) in nested.iter().enumerate() {
                assert_eq!(row, &(0..20).map(|k| i * 100 + k).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn items_keep_their_order() {
        let items: Vec<u32> = (0..50).collect();
        for threads in [1, 3] {
            assert_eq!(
                par_map_items(&items, threads, |x| x * 2),
                (0..50).map(|x| x * 2).collect::<Vec<u32>>()
            );
        }
    }

    #[test]
    fn the_current_progress_reaches_the_workers() {
        let p = crate::progress::Progress::new();
        p.cancel();
        let seen = p.run(|| {
            Ok(par_map(8, 4, |_| {
                crate::progress::checkpoint() == Err(crate::LabError::Cancelled)
            }))
        });
        // Cancelled work ends Cancelled; run the check without cancel to see the workers.
        assert_eq!(seen, Err(crate::LabError::Cancelled));
        let p = crate::progress::Progress::new();
        let seen = p.run(|| {
            Ok(par_map(8, 4, |i| {
                crate::progress::stage("w", i, 8, "");
                crate::progress::current().is_some()
            }))
        });
        assert_eq!(seen, Ok(vec![true; 8]));
    }
}
