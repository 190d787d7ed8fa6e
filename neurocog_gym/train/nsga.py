"""NSGA-II tuning of the CPG chromosome (§6.3, Table 3, Fig. 13), as a pymoo ``Problem``.

Search space: the 77 genes of ``chromosome.py`` within ``GENE_LOWER``/``GENE_UPPER``. Objectives
(both minimised): speed error |v - 0.5 m/s| and cost of transport; falling is the inequality
constraint G <= 0 (``evaluate.py`` gives the formulas). Optional, off by default so that the
problem stays Table 3's: ``max_drift`` (``--max-drift``) adds a second constraint, lateral drift
per 10 m forward minus ``max_drift`` <= 0 (a gait that walks off sideways is infeasible). Only
the genes are searched; the rest of the gait (synapses, posture, tau_f, motor constants) is the
base gait's.

Choices not fixed by the paper (SPEC §7 leaves them to us):

* Operators: SBX crossover (eta 15) and polynomial mutation (eta 20) with Table 3's probability
  0.3 each as pymoo's per-mating ``prob`` of SBX and per-individual ``prob`` of PM; per-variable
  probabilities stay pymoo's defaults (0.5 for SBX, 1/77 for PM). Duplicates are eliminated, so an
  offspring that neither operator changed is redrawn rather than evaluated twice.
* The structure gene is a real gene in [0, 1] like the others, crossed and mutated by SBX/PM; the
  decoder turns it into one of six leg rings (``ring_of``: floor(6 g)), so the operators move it
  between rings when it crosses a sixth. No integer repair is needed.
* Initial population: the base gait's chromosome, ``init_perturbed`` of the population as
  Gaussian perturbations of it (sigma ``init_sigma`` of each gene's range, clipped), and the rest
  uniform in the bounds. The paper starts from its previous research [39]; the shipped gait is
  ours.
* Generations count from 1 as pymoo's ``n_gen``: generation 1 is the initial population, so
  ``generations`` = 100 evaluates 100 populations.
* Chosen gait (``best_gait.json``): among the feasible members of the final population, those
  whose speed error is within ``speed_tol`` (0.01 m/s) of the smallest, then the lowest cost of
  transport. If no member is feasible, the one with the smallest constraint violation, marked
  ``"feasible": false`` in its notes.
* Evaluation seed: every chromosome is rolled out once with the run's seed (common random numbers:
  individuals differ only by their genes), so a result is a pure function of (genes, seed), and
  the run is the same whatever the number of workers or their scheduling.

Run folder ``DIR``:

* ``run.json``: the run's configuration, base gait and a hash of the MJCF (written first;
  ``--resume`` reads it, and warns if the robot model has changed since).
* ``history.jsonl``: one line per finished generation: ``generation`` (from 1), the population's
  ``X`` (n, 77), ``F`` (n, 2) and ``G`` (n, 1), ``n_evals`` (cumulative), ``evals`` (this
  generation), ``wall_s`` (this generation) and ``elapsed_s`` (cumulative over resumes).
* ``checkpoint.pkl``: the pickled pymoo algorithm (population, RNG state, termination) after the
  last finished generation, written atomically (temp file + rename). The history line of a
  generation is appended *before* its checkpoint; on resume lines past the checkpoint are dropped
  and that generation is run again — with the restored RNG it gives the same result.
* ``pareto.json``, ``best_gait.json``, ``fitness.png`` (Fig. 13), ``cpg.png`` (Fig. 14) at the end.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import pickle
import socket
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np
from pymoo.core.problem import Problem
from pymoo.core.sampling import Sampling

from neurocog_gym import io as nio
from neurocog_gym import paths
from neurocog_gym.locomotion.chromosome import GENE_LOWER, GENE_UPPER, N_GENES, gene_name
from neurocog_gym.locomotion.gait import Gait, default_gait
from neurocog_gym.train.evaluate import (
    EvalParams,
    GaitEvaluator,
    _worker_evaluate,
    _worker_init,
    score_row,
)

RUN_FORMAT = "neurocog-nsga-run/1"
CHECKPOINT_FORMAT = "neurocog-nsga-checkpoint/1"
RUN_FILE = "run.json"
HISTORY_FILE = "history.jsonl"
CHECKPOINT_FILE = "checkpoint.pkl"
PARETO_FILE = "pareto.json"
BEST_GAIT_FILE = "best_gait.json"
MIN_POP_SIZE = 4


@dataclass(frozen=True)
class NSGAConfig:
    """NSGA-II hyper-parameters (Table 3) and the run's seed; kept apart from ``EvalParams``."""

    pop_size: int = 128
    """Population size (Table 3)."""
    generations: int = 100
    """Number of generations, the initial population included (Table 3)."""
    crossover_prob: float = 0.3
    """SBX probability per mating (Table 3)."""
    mutation_prob: float = 0.3
    """Polynomial-mutation probability per individual (Table 3)."""
    sbx_eta: float = 15.0
    """SBX distribution index (pymoo's NSGA-II default)."""
    pm_eta: float = 20.0
    """PM distribution index (pymoo's NSGA-II default)."""
    init_perturbed: float = 0.25
    """Share of the initial population drawn around the base chromosome."""
    init_sigma: float = 0.05
    """Standard deviation of those draws, as a fraction of each gene's range."""
    speed_tol: float = 0.01
    """Speed-error tolerance of the chosen-gait rule, m/s."""
    max_drift: float = 0.0
    """Most lateral drift per 10 m forward, m, as a second constraint; 0 is off (Table 3)."""
    seed: int = 0
    """Seed of the algorithm and of every evaluation."""
    eval: EvalParams = field(default_factory=EvalParams)
    """How one chromosome is evaluated (``seconds`` = Table 3's 10 s)."""

    def __post_init__(self):
        if self.pop_size < MIN_POP_SIZE:
            raise ValueError(f"pop-size must be at least {MIN_POP_SIZE}, got {self.pop_size}")
        if self.generations < 1:
            raise ValueError(f"generations must be at least 1, got {self.generations}")
        for name in ("crossover_prob", "mutation_prob", "init_perturbed"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")
        if not self.max_drift >= 0:
            raise ValueError(f"max-drift must be >= 0 (0 = off), got {self.max_drift}")

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, raw: dict) -> NSGAConfig:
        """Inverse of :meth:`to_json`."""
        names = {f.name for f in fields(cls)}
        kw = {k: v for k, v in raw.items() if k in names and k != "eval"}
        # a config from before EvalParams.body was evaluated on body v1
        return cls(**kw, eval=EvalParams(**{"body": "v1", **raw.get("eval", {})}))


# -- the pymoo problem ---------------------------------------------------------------------------


class CPGProblem(Problem):
    """The 77-gene CPG tuning problem: 2 objectives, 1 or 2 inequality constraints.

    The constraints are falling and, when ``max_drift`` > 0, lateral drift.
    ``_evaluate`` hands the whole population to ``mapper`` (a callable from a list of (77,)
    chromosomes to a list of ``evaluate.score_row`` tuples: speed error, cost of transport, fall
    G, drift per 10 m): a process pool, a Ray pool, or, when None, this process. The mapper is
    not pickled with the problem.

    Args:
        base_gait: gait whose genes are replaced.
        eval_params: evaluation settings.
        seed: evaluation seed.
        mapper: parallel map over chromosomes, or None.
        max_drift: most lateral drift per 10 m forward, m; 0 leaves the constraint out.
    """

    def __init__(self, base_gait: Gait, eval_params: EvalParams, seed: int, mapper=None,
                 max_drift: float = 0.0):  # fmt: skip
        n_constr = 2 if max_drift > 0 else 1
        super().__init__(n_var=N_GENES, n_obj=2, n_ieq_constr=n_constr, xl=GENE_LOWER,
                         xu=GENE_UPPER)  # fmt: skip
        self.base_gait = base_gait
        self.eval_params = eval_params
        self.seed = int(seed)
        self.mapper = mapper
        self.max_drift = float(max_drift)
        self._local: GaitEvaluator | None = None

    def __getstate__(self):
        state = self.__dict__.copy()
        state["mapper"] = None
        state["_local"] = None
        return state

    def _map(self, rows: list[np.ndarray]) -> list[tuple[float, ...]]:
        if self.mapper is not None:
            return list(self.mapper(rows))
        if self._local is None:
            self._local = GaitEvaluator(self.base_gait, self.eval_params)
        return [score_row(self._local.evaluate(x, self.seed)) for x in rows]

    def _evaluate(self, X, out, *args, **kwargs):
        res = np.asarray(self._map([np.asarray(x, dtype=np.float64) for x in X]), dtype=np.float64)
        out["F"] = res[:, :2]
        max_drift = getattr(self, "max_drift", 0.0)  # checkpoints from before the option
        if max_drift > 0:
            out["G"] = np.column_stack([res[:, 2], res[:, 3] - max_drift])
        else:
            out["G"] = res[:, 2:3]


class BaseGaitSampling(Sampling):
    """Initial population around a base chromosome (module docstring)."""

    def __init__(self, base_genes: np.ndarray, perturbed: float, sigma: float):
        super().__init__()
        self.base_genes = np.asarray(base_genes, dtype=np.float64)
        self.perturbed = float(perturbed)
        self.sigma = float(sigma)

    def _do(self, problem, n_samples, *args, random_state=None, **kwargs):
        lo, hi = problem.xl, problem.xu
        X = lo + (hi - lo) * random_state.random((n_samples, problem.n_var))
        n_pert = min(int(round(self.perturbed * n_samples)), n_samples - 1)
        noise = random_state.normal(0.0, self.sigma, (n_pert, problem.n_var)) * (hi - lo)
        X[1 : 1 + n_pert] = np.clip(self.base_genes + noise, lo, hi)
        X[0] = np.clip(self.base_genes, lo, hi)
        return X


def make_algorithm(config: NSGAConfig, base_genes: np.ndarray):
    """The pymoo NSGA-II of Table 3 (see the module docstring for the operators)."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM

    return NSGA2(
        pop_size=config.pop_size,
        sampling=BaseGaitSampling(base_genes, config.init_perturbed, config.init_sigma),
        crossover=SBX(prob=config.crossover_prob, eta=config.sbx_eta),
        mutation=PM(prob=config.mutation_prob, eta=config.pm_eta),
        eliminate_duplicates=True,
    )


# -- parallel evaluation backends ----------------------------------------------------------------


def default_workers() -> int:
    """All cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


class LocalPool:
    """Evaluate on ``workers`` local processes (``spawn`` context); results in input order.

    Workers die with the run (Linux ``PR_SET_PDEATHSIG``), so a SIGKILL leaves none behind.
    """

    def __init__(self, workers: int, base_gait: Gait, params: EvalParams, seed: int):
        self.workers = workers
        self._pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_worker_init,
            initargs=(base_gait, params, seed, True),
        )

    def __call__(self, rows: list[np.ndarray]) -> list[tuple[float, float, float]]:
        """Evaluate ``rows`` in parallel."""
        return list(self._pool.map(_worker_evaluate, rows, chunksize=1))

    def close(self) -> None:
        """Stop the workers."""
        self._pool.shutdown(wait=True, cancel_futures=True)


def _check_ray_address(address: str, timeout: float = 5.0) -> None:
    """Fail fast, with one line, when a ``host:port`` Ray address does not answer."""
    if address in ("auto", "local"):
        return
    hostport = address.split("://", 1)[-1]
    host, sep, port = hostport.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ValueError(f"Ray address {address!r} is not of the form host:port or ray://host:port")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout):
            pass
    except OSError as e:
        raise ConnectionError(f"cannot reach the Ray cluster at {address}: {e}") from None


class RayPool:
    """Evaluate on an existing Ray cluster through ``ray.util.multiprocessing.Pool``.

    Each actor runs the same initializer and task as a local worker, so results do not depend on
    where they ran. An unreachable address fails within seconds with one line.

    Args:
        address: the cluster's address (``host:port``, ``ray://host:port`` or ``auto``).
        workers: actors in the pool; None is every CPU of the cluster.
        base_gait: gait whose genes are replaced.
        params: evaluation settings.
        seed: evaluation seed.
    """

    def __init__(self, address: str, workers: int | None, base_gait, params, seed: int):
        _check_ray_address(address)
        try:
            import ray
            from ray.util.multiprocessing import Pool
        except ImportError:
            raise RuntimeError(
                "--ray-address needs ray (pip install 'neurocog-gym[distributed]')"
            ) from None
        import logging

        try:
            if not ray.is_initialized():
                ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
            self._pool = Pool(processes=workers, initializer=_worker_init,
                              initargs=(base_gait, params, seed))  # fmt: skip
        except (ConnectionError, ValueError) as e:
            raise ConnectionError(f"Ray cluster at {address}: {_first_line(e)}") from None
        except Exception as e:  # ray raises its own types for a cluster it cannot use
            raise RuntimeError(f"Ray cluster at {address}: {_first_line(e)}") from None
        self.workers = workers

    def __call__(self, rows: list[np.ndarray]) -> list[tuple[float, float, float]]:
        """Evaluate ``rows`` on the cluster."""
        return list(self._pool.map(_worker_evaluate, rows, chunksize=1))

    def close(self) -> None:
        """Stop the actors and disconnect."""
        import ray

        self._pool.terminate()
        ray.shutdown()


class SerialPool:
    """Evaluate in this process (``workers=1``): no start-up cost, same results."""

    workers = 1

    def __init__(self, base_gait: Gait, params: EvalParams, seed: int):
        self._evaluator = GaitEvaluator(base_gait, params)
        self._seed = seed

    def __call__(self, rows):
        """Evaluate ``rows`` one after the other."""
        return [score_row(self._evaluator.evaluate(x, self._seed)) for x in rows]

    def close(self) -> None:
        """Nothing to stop."""


def make_pool(workers: int | None, ray_address: str | None, base_gait, params, seed: int):
    """The evaluation backend: Ray when an address is given, else local processes."""
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if ray_address:
        return RayPool(ray_address, workers, base_gait, params, seed)
    workers = workers or default_workers()
    if workers == 1:
        return SerialPool(base_gait, params, seed)
    return LocalPool(workers, base_gait, params, seed)


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


# -- results ---------------------------------------------------------------------------------------


def choose_gait(F: np.ndarray, G: np.ndarray, speed_tol: float = 0.01) -> int:
    """Index of the chosen solution (module docstring: closest to v*, then lowest CoT).

    Args:
        F: (n, 2) speed error (m/s) and cost of transport.
        G: (n, 1) or (n,) fall constraint (<= 0 feasible).
        speed_tol: speed errors within this of the best count as equal, m/s.
    """
    F = np.asarray(F, dtype=np.float64)
    g = np.asarray(G, dtype=np.float64).reshape(len(F), -1).max(axis=1)
    feasible = np.flatnonzero(g <= 0.0)
    if len(feasible) == 0:
        return int(np.lexsort((F[:, 0], g))[0])
    best = F[feasible, 0].min()
    near = feasible[F[feasible, 0] <= best + speed_tol]
    return int(near[np.lexsort((F[near, 0], F[near, 1]))[0]])


@dataclass(frozen=True)
class TuneResult:
    """What :func:`tune_cpg` produced."""

    out: Path
    """The run folder."""
    generations: int
    """Generations finished."""
    n_evals: int
    """Evaluations in all."""
    elapsed_s: float
    """Wall time over all sessions, s."""
    best_index: int
    """Index of the chosen solution in the final population."""
    best_F: tuple[float, float]
    """Its (speed error, cost of transport)."""
    feasible: bool
    """Whether it is feasible."""


# -- run folder ----------------------------------------------------------------------------------


def _load_checkpoint(path: Path) -> dict:
    try:
        with open(path, "rb") as f:
            ck = pickle.load(f)
    except FileNotFoundError:
        raise
    except Exception as e:  # any unpickling failure means the file cannot be used
        raise ValueError(f"checkpoint {path} is unreadable or corrupt ({_first_line(e)})") from None
    if not isinstance(ck, dict) or ck.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"checkpoint {path} is not a {CHECKPOINT_FORMAT} file")
    return ck


def _save_checkpoint(path: Path, algorithm, generation: int, elapsed: float) -> None:
    ck = {"format": CHECKPOINT_FORMAT, "generation": generation, "algorithm": algorithm,
          "elapsed_s": elapsed}  # fmt: skip
    nio.atomic_write_bytes(path, pickle.dumps(ck, protocol=pickle.HIGHEST_PROTOCOL))


def read_run(out: str | os.PathLike) -> tuple[NSGAConfig, Gait]:
    """The configuration and base gait of the run in ``out`` (its ``run.json``)."""
    out = Path(out)
    path = out / RUN_FILE
    if not path.exists():
        raise FileNotFoundError(f"{out} holds no run to resume ({RUN_FILE} is missing)")
    try:
        raw = json.loads(path.read_text())
        if raw.get("format") != RUN_FORMAT:
            raise ValueError(f"not a {RUN_FORMAT} file")
        config = NSGAConfig.from_json(raw["config"])
        base_gait = Gait.from_dict(raw["base_gait"])
    except (ValueError, KeyError, TypeError) as e:
        raise ValueError(f"run file {path} is unreadable or corrupt ({_first_line(e)})") from None
    return config, base_gait


def _history_record(algorithm, generation: int, evals: int, wall: float, elapsed: float) -> dict:
    pop = algorithm.pop
    return {
        "generation": generation,
        "n_evals": int(algorithm.evaluator.n_eval),
        "evals": int(evals),
        "wall_s": round(wall, 4),
        "elapsed_s": round(elapsed, 4),
        "F": pop.get("F").tolist(),
        "G": pop.get("G").tolist(),
        "X": pop.get("X").tolist(),
    }


def read_history(out: str | os.PathLike) -> list[dict]:
    """The finished generations of a run folder, in order."""
    return nio.read_jsonl(Path(out) / HISTORY_FILE)


def _truncate_history(out: Path, generation: int) -> None:
    """Keep generations 1..generation of ``history.jsonl`` (atomically), checking all are there."""
    records = [r for r in read_history(out) if r.get("generation", 0) <= generation]
    gens = [r["generation"] for r in records]
    if gens != list(range(1, generation + 1)):
        raise ValueError(
            f"{out / HISTORY_FILE} does not hold generations 1..{generation} of the checkpoint"
        )
    text = "".join(json.dumps(r, separators=(",", ":")) + "\n" for r in records)
    nio.atomic_write_text(out / HISTORY_FILE, text)


# -- the run ---------------------------------------------------------------------------------------


def tune_cpg(
    out: str | os.PathLike,
    config: NSGAConfig | None = None,
    *,
    workers: int | None = None,
    ray_address: str | None = None,
    resume: bool = False,
    base_gait: Gait | None = None,
    generations: int | None = None,
    plots: bool = True,
    progress: bool = True,
) -> TuneResult:
    """Run (or resume) NSGA-II on the CPG chromosome and write the run folder.

    Args:
        out: run folder (module docstring lists its files).
        config: hyper-parameters of a new run (ignored on resume: the folder's are used).
        workers: parallel evaluations; None is every local core (or every Ray CPU).
        ray_address: evaluate on this existing Ray cluster instead of local processes.
        resume: continue the run in ``out`` from its last checkpoint.
        base_gait: gait whose genes are searched; None is the shipped default (read now).
        generations: on resume, a new total number of generations (None keeps the run's).
        plots: write Fig. 13 and Fig. 14 at the end.
        progress: show a tqdm bar (hidden anyway when stderr is not a terminal).

    Returns:
        A summary; the chosen gait is ``out/best_gait.json``.
    """
    from pymoo.termination.max_gen import MaximumGenerationTermination
    from tqdm import tqdm

    out = Path(out)
    ck_path = out / CHECKPOINT_FILE
    if resume:
        config, base_gait = read_run(out)
        _warn_if_model_changed(out)
        ck = _load_checkpoint(ck_path) if ck_path.exists() else None
        if generations is not None:
            done = ck["generation"] if ck else 0
            if generations < done:
                raise ValueError(
                    f"the run already has {done} generations; cannot cut to {generations}"
                )
            config = replace(config, generations=generations)
            _write_run(out, config, base_gait)
    else:
        config = config or NSGAConfig()
        if (out / RUN_FILE).exists() or ck_path.exists():
            raise FileExistsError(f"{out} already holds a run; use --resume or another --out")
        base_gait = base_gait if base_gait is not None else default_gait()
        ck = None

    if ck is not None:
        algorithm = ck["algorithm"]
        done, elapsed = int(ck["generation"]), float(ck["elapsed_s"])
        algorithm.termination = MaximumGenerationTermination(config.generations)
        problem = algorithm.problem
    else:
        problem = CPGProblem(base_gait, config.eval, config.seed, max_drift=config.max_drift)
        algorithm = make_algorithm(config, base_gait.genes_array)
        algorithm.setup(problem, termination=("n_gen", config.generations), seed=config.seed,
                        verbose=False)  # fmt: skip
        done, elapsed = 0, 0.0
    pool = None
    if done < config.generations:
        # Before anything is written: a bad worker count or Ray address leaves no half-made run.
        pool = make_pool(workers, ray_address, base_gait, config.eval, config.seed)
    try:
        if not resume:
            out.mkdir(parents=True, exist_ok=True)
            _write_run(out, config, base_gait)
        if (out / HISTORY_FILE).exists():
            _truncate_history(out, done)
        problem.mapper = pool
        bar = tqdm(total=config.generations, initial=done, desc="NSGA-II", unit="gen",
                   disable=None if progress else True, file=sys.stderr)  # fmt: skip
        while done < config.generations and algorithm.has_next():
            t0 = time.perf_counter()
            infills = algorithm.ask()
            n0 = algorithm.evaluator.n_eval
            algorithm.evaluator.eval(problem, infills, algorithm=algorithm)
            algorithm.tell(infills=infills)
            wall = time.perf_counter() - t0
            done += 1
            elapsed += wall
            evals = algorithm.evaluator.n_eval - n0
            nio.append_jsonl(out / HISTORY_FILE,
                             _history_record(algorithm, done, evals, wall, elapsed))  # fmt: skip
            _save_checkpoint(ck_path, algorithm, done, elapsed)
            F, G = algorithm.pop.get("F"), algorithm.pop.get("G")
            ok = G[:, 0] <= 0
            bar.set_postfix(feasible=int(ok.sum()),
                            best_err=f"{F[ok, 0].min():.3f}" if ok.any() else "-",
                            evals_per_s=f"{evals / max(wall, 1e-9):.1f}")  # fmt: skip
            bar.update(1)
        bar.close()
    finally:
        problem.mapper = None
        if pool is not None:
            pool.close()

    return _finish(out, algorithm, config, base_gait, done, elapsed, plots)


def model_fingerprint() -> str:
    """SHA-256 of the robot and scene MJCF: a resumed run warns when the model changed."""
    import hashlib

    h = hashlib.sha256()
    for name in (paths.ROBOT_XML, paths.SCENE_XML):
        h.update(paths.asset(name).read_bytes())
    return h.hexdigest()


def _write_run(out: Path, config: NSGAConfig, base_gait: Gait) -> None:
    nio.atomic_write_json(out / RUN_FILE, {"format": RUN_FORMAT, "config": config.to_json(),
                                           "base_gait": base_gait.to_json(),
                                           "model_sha256": model_fingerprint()})  # fmt: skip


def _warn_if_model_changed(out: Path) -> None:
    stored = json.loads((out / RUN_FILE).read_text()).get("model_sha256")
    if stored and stored != model_fingerprint():
        print(f"neurocog tune-cpg: warning: the robot MJCF changed since the run in {out} started; "
              "the resumed generations use the new model", file=sys.stderr)  # fmt: skip


def _finish(out, algorithm, config, base_gait, done, elapsed, plots) -> TuneResult:
    pop = algorithm.pop
    X, F, G = pop.get("X"), pop.get("F"), pop.get("G")
    i = choose_gait(F, G, config.speed_tol)
    feasible = bool(G[i].max() <= 0)
    front = algorithm.opt
    nio.atomic_write_json(out / PARETO_FILE, {
        "generation": done,
        "objectives": ["speed_error_m_per_s", "cost_of_transport"],
        "constraint": "G = 1 - t_fall / T (<= 0 feasible)" + (
            f"; G2 = drift per 10 m - {config.max_drift} m (<= 0 feasible)"
            if config.max_drift > 0 else ""),
        "gene_names": [gene_name(k) for k in range(N_GENES)],
        "F": front.get("F").tolist(),
        "G": front.get("G").tolist(),
        "X": front.get("X").tolist(),
        "chosen": {"F": F[i].tolist(), "G": G[i].tolist(), "X": X[i].tolist()},
    })  # fmt: skip
    evaluator = GaitEvaluator(base_gait, config.eval)
    if plots:
        from neurocog_gym.train.nsga_plots import plot_cpg_outputs, plot_fitness_history

        plot_fitness_history(read_history(out), out / "fitness.png")
        score, trace = evaluator.trace(X[i], config.seed)
        plot_cpg_outputs(trace, out / "cpg.png")
    else:
        score = evaluator.evaluate(X[i], config.seed)
    # Fresh notes: the base gait's own measurements (speed, CoT, clearance...) do not describe
    # the tuned genes, so they are not carried over.
    gait = replace(base_gait, notes={}).with_genes(
        X[i],
        name="nsga-tuned",
        tuned_by="neurocog tune-cpg (NSGA-II, §6.3)",
        feasible=feasible,
        speed=score.speed,
        speed_error=float(F[i, 0]),
        cost_of_transport=float(F[i, 1]),
        generation=done,
        seed=config.seed,
        eval_seconds=config.eval.seconds,
        base_gait=base_gait.name,
        drift_per_10m=score.drift_per_10m,
        heading_change_rad=score.heading_change,
        **({"max_drift": config.max_drift} if config.max_drift > 0 else {}),
    )
    gait.save(out / BEST_GAIT_FILE)
    return TuneResult(out=out, generations=done, n_evals=int(algorithm.evaluator.n_eval),
                      elapsed_s=elapsed, best_index=i, best_F=(float(F[i, 0]), float(F[i, 1])),
                      feasible=feasible)  # fmt: skip


def tune_cpg_cli(
    out: str | os.PathLike,
    *,
    pop_size: int | None = None,
    generations: int | None = None,
    eval_seconds: float | None = None,
    seed: int | None = None,
    workers: int | None = None,
    ray_address: str | None = None,
    resume: bool = False,
    base_gait: str | os.PathLike | None = None,
    max_drift: float | None = None,
    progress: bool = True,
) -> TuneResult:
    """``neurocog tune-cpg``: :func:`tune_cpg` from command-line values (None = default).

    On ``resume`` the run's own population size, seed, evaluation length and base gait are used;
    giving a different value is an error (``generations`` may change the total).
    """
    out = Path(out)
    gait = Gait.load(base_gait) if base_gait is not None else None
    if resume:
        config, run_gait = read_run(out)
        given = {"pop-size": (pop_size, config.pop_size), "seed": (seed, config.seed),
                 "eval-seconds": (eval_seconds, config.eval.seconds),
                 "max-drift": (max_drift, config.max_drift)}  # fmt: skip
        for name, (value, stored) in given.items():
            if value is not None and value != stored:
                raise ValueError(f"--{name} {value} differs from the run's {stored}; drop it "
                                 "with --resume")  # fmt: skip
        if gait is not None and gait.to_json() != run_gait.to_json():
            raise ValueError(f"--base-gait {base_gait} differs from the run's base gait")
        return tune_cpg(out, workers=workers, ray_address=ray_address, resume=True,
                        generations=generations, progress=progress)  # fmt: skip
    defaults = NSGAConfig()
    config = NSGAConfig(
        pop_size=defaults.pop_size if pop_size is None else pop_size,
        generations=defaults.generations if generations is None else generations,
        seed=defaults.seed if seed is None else seed,
        max_drift=defaults.max_drift if max_drift is None else max_drift,
        eval=EvalParams(seconds=defaults.eval.seconds if eval_seconds is None else eval_seconds),
    )
    return tune_cpg(out, config, workers=workers, ray_address=ray_address, base_gait=gait,
                    progress=progress)  # fmt: skip
