"""`Study`: one object that owns a study folder, as an emcee backend owns a chain.

The stages (`filmcal.fem`, `filmcal.campaign`, `filmcal.surrogate`,
`filmcal.calibration`, `filmcal.correction`) know nothing of folders; a
`Study` composes them and is the only code that reads and writes the folder
(through `StudyLayout`). Every artefact is named by the key of the spec that
made it and recorded in the manifest with its SHA-256:

* asked for an artefact, the study computes the spec's key; a recorded file
  with that key is verified and reused, otherwise it is computed and recorded
  beside any made with other settings (never reused silently);
* a file changed after it was written is refused with a message that names it;
* one process writes a study at a time (`Study.writing`, an OS file lock).
"""
from __future__ import annotations

import contextlib
import os
import warnings
import zlib
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator

import numpy as np

from filmcal._errors import InputError, UntrustedArtefactError
from filmcal._io import canonical_json, check_output_dir
from filmcal._versions import VersionNote, version_note
from filmcal.contact.names import DEFAULT_KINEMATICS, FE_MODEL_REVISION, IMPRINT_MODELS, KINEMATICS
from filmcal.contact.options import ContactOptions
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON
from filmcal.films import FilmRegistry, FilmType, load_films_file
from filmcal.study.layout import StudyLayout, spec_key
from filmcal.study.manifest import Manifest, StudyLock, utc_now

if TYPE_CHECKING:
    from filmcal._parallel import Executor

__all__ = ["Study", "FESettings", "CalibrationSpec", "IMPRINT_MODELS", "KINEMATICS", "seed_for", "output_column", "correctors", "comparison_weights", "report_view",
           "chosen_posteriors", "curve_components", "film_model", "SHARED_STORE_WAIT_S", "RUN_STORE_VARIABLE",
           "default_run_store"]

#: How long a study waits for another study writing the same shared run store (s): as long as such a campaign
#: may run; the runs it finishes are then reused.
SHARED_STORE_WAIT_S = 24 * 3600.0

#: Numeric outputs of a run that are no result of it (timing): left out of the content hash a study records of
#: the runs it used, so that runs computed again elsewhere are recognised as the same.
RUN_BOOKKEEPING_OUTPUTS = frozenset({"elapsed_s"})

#: Environment variable that sets the run store of new studies given none: a folder, or ``study`` for each
#: study's own ``runs/`` folder.
RUN_STORE_VARIABLE = "FILMCAL_RUN_STORE"


def default_run_store() -> Path | None:
    """The run store a new study uses when it is given none.

    ``$FILMCAL_RUN_STORE`` when set (``study``: None, the study's own ``runs/`` folder), else the user's cache
    folder, ``$XDG_CACHE_HOME/filmcal/runs`` (``~/.cache/filmcal/runs``), so that every study of this user with
    the same FE (or simulator) settings reuses the same runs. None when that folder cannot be made or written.
    """
    value = os.environ.get(RUN_STORE_VARIABLE, "").strip()
    if value == "study":
        return None
    if value:
        return Path(value).expanduser().resolve()
    try:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
        path = base / "filmcal" / "runs"
        path.mkdir(parents=True, exist_ok=True)
    except (OSError, RuntimeError):  # no home, a read-only one
        return None
    return path.resolve() if os.access(path, os.W_OK) else None


def as_recorded(settings: dict) -> dict:
    """`settings` as a study's manifest records them (JSON values: lists for tuples, plain floats)."""
    import json

    from filmcal._json import json_safe

    return json.loads(json.dumps(json_safe(settings)))


def seed_for(seed: int, stream: str) -> int:
    """An independent integer seed of the named stream of a study's seed.

    Every random step of a study draws from its own stream
    (`numpy.random.SeedSequence` with the stream's name as spawn key), so that
    adding a stage or a film never shifts the random numbers of another.
    """
    ss = np.random.SeedSequence(entropy=int(seed), spawn_key=(zlib.crc32(stream.encode()),))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


@dataclass(frozen=True)
class FESettings:
    """What a study's FE campaign and radius surrogates are made from.

    Attributes
    ----------
    sphere_contact, flat_contact, friction_coefficient : FE contact options.
    kinematics : {"small", "large"}
        Small-strain or large-strain (neo-Hookean) film.
    film_thickness_mm : float
        Film thickness of the FE model.
    n_train, n_test : int
        FE runs of the surrogate's training design and of its held-out design.
    seed : int
        The study's seed (designs and GP restarts draw from their own streams).
    domain : SurrogateDomain, optional
        Where the surrogates are trained (default: Table 1's experiments with margins).
    base_domain : SurrogateDomain, optional
        The domain that `domain` extends to cover a dataset (`_covering_spec`): the designs are then that
        domain's, augmented (`filmcal.surrogate.radius.design_points`), so that its runs are reused.
    simulator : filmcal.campaign.simulator.Simulator, optional
        A lab's own simulator in place of the in-house FE (its runs then make the surrogates; the contact
        options and kinematics above are the in-house FE's and do not reach it).
    body_modulus_mpa, body_poisson : float
        Elastic constants of the FE's sphere and flat (default steel; a dataset's own bodies,
        `_bodies_spec`). Left out of the spec when steel, as before they existed.
    moduli_per_case : int
        FE runs added to the training design at each of the dataset's (R, F) cases, at moduli spread over
        the domain (`filmcal.surrogate.radius.case_design_points`); 0: the Latin hypercube alone.
    case_points : tuple of (float, float, float)
        The dataset's cases ``(sphere_radius_mm, force_kn, poisson)`` those runs are made at, set from the
        data by `_covering_spec` (at most ``n_train`` runs in all). Both are left out of the spec when there
        are none, as before they existed; they are not in the run store's spec (a run is a run wherever
        it was asked for).
    """

    sphere_contact: str = ContactOptions.sphere_contact
    flat_contact: str = ContactOptions.flat_contact
    friction_coefficient: float = ContactOptions.friction_coefficient
    kinematics: str = DEFAULT_KINEMATICS
    film_thickness_mm: float = 0.09
    n_train: int = 200
    n_test: int = 100
    seed: int = 0
    domain: Any = None
    simulator: Any = None
    base_domain: Any = None
    body_modulus_mpa: float = STEEL_MODULUS_MPA
    body_poisson: float = STEEL_POISSON
    moduli_per_case: int = 0
    case_points: tuple = ()

    def __post_init__(self) -> None:
        from filmcal.surrogate.radius import SurrogateDomain, check_moduli_per_case

        if self.domain is None:
            object.__setattr__(self, "domain", SurrogateDomain())
        if self.kinematics not in KINEMATICS:
            raise InputError(f"kinematics must be one of {', '.join(KINEMATICS)}, got {self.kinematics!r}")
        if not (20 <= self.n_train <= 5000 and 5 <= self.n_test <= 5000):
            raise InputError(f"train_runs must be 20-5000 and test_runs 5-5000, got {self.n_train} and {self.n_test}")
        check_moduli_per_case(self.moduli_per_case)
        object.__setattr__(self, "case_points", tuple(tuple(float(v) for v in c) for c in self.case_points))

    @property
    def case_runs(self) -> int:
        """FE runs at the dataset's cases (`case_points` times `moduli_per_case`)."""
        return len(self.case_points) * self.moduli_per_case

    def as_spec(self) -> dict:
        """The settings as a spec: the in-house FE's as before, a lab's simulator by its own spec."""
        steel = (self.body_modulus_mpa, self.body_poisson) == (STEEL_MODULUS_MPA, STEEL_POISSON)
        out = {k: v for k, v in asdict(self).items()
               if k != "simulator" and not (k == "base_domain" and v is None)
               and not (steel and k in ("body_modulus_mpa", "body_poisson"))
               and not (self.case_runs == 0 and k in ("moduli_per_case", "case_points"))}
        if self.case_runs:
            out["case_points"] = [list(c) for c in self.case_points]
        if self.simulator is not None:
            out["simulator"] = self.simulator.spec()
        else:
            out["fe_model_revision"] = FE_MODEL_REVISION
        return out

    def contact_options(self) -> ContactOptions:
        return ContactOptions(sphere_contact=self.sphere_contact, flat_contact=self.flat_contact,
                              friction_coefficient=self.friction_coefficient,
                              kinematics=self.kinematics)


@dataclass(frozen=True)
class CalibrationSpec:
    """One calibration of a film in a study.

    Attributes
    ----------
    film : str
        Film type (built in, or defined in the study).
    imprint : {"edge", "activation", "capsule"}
        What the film records (the radius model's output).
    fe : FESettings
        FE options, kinematics, design sizes and seed.
    loads : str or None
        Load range of the data, e.g. ``"50-100"`` (kN); None: all.
    poisson : {"fixed", "free"}
    discrepancy : {None, "load"}
    max_steps : int or None
        Cap of MCMC steps per walker.
    """

    film: str
    imprint: str = "edge"
    fe: FESettings = field(default_factory=FESettings)
    loads: str | None = None
    poisson: str = "fixed"
    discrepancy: str | None = None
    max_steps: int | None = None

    def __post_init__(self) -> None:
        if self.imprint not in IMPRINT_MODELS:
            raise InputError(f"imprint must be one of {', '.join(IMPRINT_MODELS)}, got {self.imprint!r}")
        if self.poisson not in ("fixed", "free"):
            raise InputError(f"poisson must be fixed or free, got {self.poisson!r}")
        if self.discrepancy not in (None, "load"):
            raise InputError(f"discrepancy must be none or load, got {self.discrepancy!r}")

    @property
    def model_label(self) -> str:
        """The calibrated model's name in comparisons: imprint model and kinematics."""
        return f"{self.imprint}/{self.fe.kinematics}"


def output_column(imprint: str, film: str) -> str:
    """The FE reading that the imprint model `imprint` makes of film `film`."""
    from filmcal.surrogate.radius import EDGE_COLUMN

    return EDGE_COLUMN if imprint == "edge" else f"radius_{imprint}_{film}_mm"


#: The `filmcal calibrate` option of each key a posterior is matched by.
_MATCH_OPTIONS = {"imprint": "--imprint-model", "kinematics": "--kinematics", "poisson": "--poisson",
                  "loads": "--forces-kn"}
_MATCH_WORDS = {"imprint": "imprint model", "kinematics": "kinematics", "poisson": "nu", "loads": "forces (kN)"}


class Study:
    """A study folder: its manifest, its artefacts and the stages that make them.

    Parameters
    ----------
    root : str or Path
        The folder.
    create : bool
        Create the folder (and its manifest) when missing. Without it a
        missing folder, or a folder without a manifest, is an error: a mistyped
        ``--study-dir`` never starts a new study silently.
    films_file : str or Path, optional
        A TOML file of user film types to add to the study's films.
    read_only : bool
        Never write the folder (a server, an archive): `writing` refuses, and
        the solves a correction would keep are not kept.

    Attributes
    ----------
    manifest_sha256 : str or None
        SHA-256 of the manifest's content as it was read, its ``caches``
        aside (solves a correction keeps are no result of the study; None for
        a new study): where an answer came from.
    """

    def __init__(self, root: str | Path, *, create: bool = False, films_file: str | Path | None = None,
                 read_only: bool = False, run_store: str | Path | None = None) -> None:
        if create and read_only:
            raise ValueError("a study cannot be both created and read-only")
        self.read_only = read_only
        self.layout = StudyLayout(root)
        self.root = self.layout.root
        if run_store is None and create and not self.layout.manifest.exists():
            run_store = default_run_store()  # a new study: the user's shared store (a study made before keeps its own)
        self._run_store = None if run_store is None else Path(run_store).resolve()
        # a study whose results are only read (correct, curves, report) may be read-only: a colleague's, an
        # archive (their caches are then not kept)
        check_output_dir(self.root, "--study-dir", must_exist=not create, writable=create)
        self.manifest_sha256 = None
        if self.layout.manifest.exists():
            self.manifest = Manifest.read(self.layout.manifest)
            self.manifest_sha256 = _results_sha256(self.manifest.data)
        elif create:
            if self.root.exists() and any(p.name != ".lock" for p in self.root.iterdir()):
                raise InputError(f"--study-dir {str(self.root)!r} is a folder with files but no study manifest "
                                 f"({self.layout.manifest.name}); give an empty or new folder")
            self.manifest = Manifest.new(self.layout.manifest)
        else:
            raise InputError(f"--study-dir {str(self.root)!r} is not a study folder (no {self.layout.manifest.name}); "
                             "make one with `filmcal pipeline` or `filmcal calibrate --study-dir ...`")
        #: One line when the study was made under other versions than this process's (else None).
        self.version_note = version_note(self.manifest.data.get("software"))
        if self.version_note is not None and self.layout.manifest.exists():
            warnings.warn(VersionNote(f"study {self.root} was {self.version_note}"), stacklevel=2)
        self._lock = StudyLock(self.layout.lock)
        user = {name: FilmType.from_dict(name, d) for name, d in self.manifest.data["films"].items()}
        self.films = FilmRegistry(user)
        if films_file is not None:
            self._new_films = load_films_file(films_file)
            for name, film in self._new_films.items():
                if name in user and user[name] != film:
                    raise InputError(f"film {name} in {films_file} differs from the study's definition; "
                                     "give it another name or use another --study-dir")
            self.films = FilmRegistry({**user, **self._new_films})
        else:
            self._new_films = {}

    def __repr__(self) -> str:
        return f"Study({str(self.root)!r})"

    # ------------------------------------------------------------ writing
    @contextlib.contextmanager
    def writing(self, what: str = "", *, brief: bool = False) -> Iterator["Study"]:
        """Hold the study's writer lock; the manifest is saved on exit (also after an error). ``brief``: for a
        moment, to keep a cache (`filmcal.study.manifest.StudyLock`: a run waits for it, another brief writer
        is refused at once).

        A new study whose first writer is refused (bad input, `ValueError`) before it records anything is
        removed again (its manifest, its lock file and the folder if it made it): the refusal writes nothing,
        and the folder stays free for other data.
        """
        if self.read_only:
            raise InputError(f"study {self.root} is open read-only: {what or 'writing'} is refused")
        if self._lock.held:
            yield self
            return
        new, made_root = not self.layout.manifest.exists(), not self.root.exists()
        self.root.mkdir(parents=True, exist_ok=True)
        self._lock.acquire(what, brief=brief)
        try:
            if self.layout.manifest.exists():  # another writer may have finished since we read it
                self.manifest = Manifest.read(self.layout.manifest)
            for name, film in self._new_films.items():
                self.manifest.data["films"][name] = film.to_dict()
            if self._run_store is not None:
                self.manifest.data["run_store"] = str(self._run_store)
            self.manifest.note_writer_software()
            self.manifest.write()
            yield self
        except ValueError:
            if new and not self.manifest.data["artefacts"] and not self.manifest.data["stages"] and \
                    {p.name for p in self.root.iterdir()} <= {self.layout.manifest.name, self.layout.lock.name}:
                self.layout.manifest.unlink(missing_ok=True)
                # still held; a new study has no brief writers (they keep caches of results it lacks), and a
                # run is refused at once: no other writer waits on the file removed
                self.layout.lock.unlink(missing_ok=True)
                self._lock.release()
                if made_root:
                    self.root.rmdir()
            raise
        finally:
            if self._lock.held:
                self.manifest.write()
            self._lock.release()

    def _require_writer(self) -> None:
        if not self._lock.held:
            raise RuntimeError("a study is written inside `with study.writing():`")

    def record(self, path: Path, kind: str, spec: dict, **extra: Any) -> Path:
        """Record an artefact just written under the lock."""
        self._require_writer()
        self.manifest.record(self.layout.relative(path), path, kind, spec, **extra)
        self.manifest.write()
        return path

    def adopt(self, path: Path, kind: str, spec: dict) -> Path | None:
        """`path` recorded as an artefact of `kind` if it is a cache the study kept with this spec (its entry
        moves from the manifest's ``caches`` to its artefacts, the file unchanged); None if it is not one.

        Raises
        ------
        InputError
            If the cache was changed after the study wrote it.
        """
        self._require_writer()
        relpath = self.layout.relative(path)
        entry = (self.manifest.data.get("caches") or {}).get(relpath)
        if self.manifest.entry(relpath) is not None or _read_cache(self, path, spec, read=lambda p: p) is None:
            return None
        self.manifest.data["artefacts"][relpath] = {"kind": kind, "spec": spec, "sha256": entry["sha256"],
                                                    "written_utc": entry.get("written_utc", utc_now())}
        del self.manifest.data["caches"][relpath]
        self.manifest.write()
        return path

    def verified(self, path: Path, kind: str | None = None, spec: dict | None = None) -> Path | None:
        """`path` if it exists and is the file the study recorded; None if missing.

        The one way a study's artefact is opened: the path must stay inside the
        study once its links are resolved, and the file must be the one the
        manifest recorded (its SHA-256, and the `kind` and `spec` when given).

        Raises
        ------
        filmcal._errors.UntrustedArtefactError
            If it is not (`Manifest.verify`, `StudyLayout.relative`).
        """
        if not path.exists():
            return None
        self.manifest.verify(self.layout.relative(path), path, kind=kind, spec=spec)
        return path

    def roughness_inputs(self) -> tuple[list, str]:
        """The draws of the roughness inputs the study's corrections and curves use, and where they come from.

        The draws conditioned again on the study's own roughened-flat data (``roughness-inputs.json``, made
        by the pipeline's roughness stage) when the study has them, else the shipped conditioned draws
        (`filmcal.contact.rough_imprint.load_roughness_inputs`).
        """
        from filmcal.contact.rough_imprint import RoughnessInputs, load_roughness_inputs

        path = self.layout.roughness_inputs
        if self.verified(path, kind="roughness-inputs") is None:
            return load_roughness_inputs(), "conditioned draws shipped with filmcal (filmcal/data/roughness_inputs.json)"
        from filmcal._io import read_json

        data = read_json(path)
        return ([RoughnessInputs.from_dict(d) for d in data["conditioned"]],
                f"the shipped draws conditioned again on this study's roughened-flat data ({path.name}: "
                f"{len(data['observations'])} observations, {data['effective_draws']:.1f} effective draws)")

    def film(self, name: str) -> FilmType:
        """A film type known to the study (built in, from the manifest or the films file)."""
        try:
            return self.films.get(name)
        except ValueError as exc:  # a study's films are those it was calibrated with
            raise InputError(str(exc).replace("(add your own with --films-file)",
                                              f"(the films study {self.root} knows; a study takes its own "
                                              "films with calibrate --films-file)")) from None

    def set_settings(self, settings: dict) -> None:
        """Record the study's settings on first use; refuse other settings later (naming what differs)."""
        self._require_writer()
        settings = as_recorded(settings)
        old = self.manifest.data.get("settings")
        if old is not None and old != settings:
            a, b = _flatten(old), _flatten(settings)
            diff = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            raise InputError(f"study {self.root} was made with other settings "
                             f"({'; '.join(f'{k} {a.get(k)!r} -> {b.get(k)!r}' for k in diff)}); "
                             "use another --study-dir")
        self.manifest.data["settings"] = settings
        self.manifest.write()

    def stage_done(self, name: str, elapsed_s: float, **info: Any) -> None:
        """Record the timing of a stage run that computed something."""
        self.manifest.data["stages"][name] = {"elapsed_s": round(float(elapsed_s), 3), "finished_utc": utc_now(),
                                              **info}
        if self._lock.held:
            self.manifest.write()

    # ------------------------------------------------------------ FE runs and surrogates
    def _fe_films(self, thickness_mm: float) -> tuple[FilmType, ...]:
        """The study's films with an activation pressure and this thickness (their imprint readings)."""
        return tuple(self.films.get(n) for n in self.films.names()
                     if self.films.get(n).has_activation and abs(self.films.get(n).thickness_mm - thickness_mm) < 1e-12)

    def _store_spec(self, fe: FESettings) -> dict:
        films = self._fe_films(fe.film_thickness_mm)
        return {"kind": "fe-runs", "options": {k: v for k, v in fe.as_spec().items()
                                              if k not in ("n_train", "n_test", "seed", "domain", "base_domain",
                                                           "moduli_per_case", "case_points")},
                "films": [f.to_dict() for f in films]}

    def fe_runs(self, fe: FESettings, workers: int | Executor | None = None, progress=None) -> dict:
        """Run (or resume) the FE training and held-out designs; return inputs and every output column.

        Returns
        -------
        dict
            ``X_train``, ``X_test`` (input name -> array), ``Y_train``, ``Y_test``
            (output column -> array, NaN where a run failed) and ``store`` (path).
        """
        from functools import partial

        from filmcal._parallel import Executor
        from filmcal.campaign import Campaign
        from filmcal.fem import evaluate_point
        from filmcal.surrogate.radius import INPUTS, case_design_points, design_points

        self._require_writer()
        domain = fe.domain
        options = fe.contact_options()
        train = design_points(domain, fe.n_train, seed_for(fe.seed, "design-train"), options, fe.base_domain)
        train += case_design_points(domain, fe.case_points, fe.moduli_per_case, options)
        test = design_points(domain, fe.n_test, seed_for(fe.seed, "design-test"), options, fe.base_domain)
        films = self._fe_films(fe.film_thickness_mm)
        for p in train + test:
            p["film_thickness_mm"] = fe.film_thickness_mm
            if (fe.body_modulus_mpa, fe.body_poisson) != (STEEL_MODULUS_MPA, STEEL_POISSON):
                p["body_modulus_mpa"], p["body_poisson"] = fe.body_modulus_mpa, fe.body_poisson
        store_spec = self._store_spec(fe)
        store = self.runs_store(spec_key(store_spec))
        try:
            store.parent.mkdir(parents=True, exist_ok=True)
            if not os.access(store.parent, os.W_OK):
                raise PermissionError("not writable")
        except OSError as exc:  # e.g. a colleague's study whose store lies in their home
            raise InputError(f"the study's run store {store.parent} cannot be used ({exc.strerror or exc}): give "
                             f"--run-store DIR (or set {RUN_STORE_VARIABLE}) to keep its FE runs elsewhere") from None
        if fe.simulator is not None:
            from filmcal.fem import imprint_columns

            pairs = [(m, film) for m, film, _ in imprint_columns(films)]
            model = fe.simulator.model(pairs, store.with_suffix(".work"))
        else:
            model = partial(evaluate_point, films=films) if films else evaluate_point
        pool = {"executor": workers} if isinstance(workers, Executor) else {"workers": workers}
        campaign = Campaign(model, store, settings={"spec": store_spec}, **pool)
        shared = store.parent != self.layout.runs_store(spec_key(store_spec)).parent

        def waiting(holder) -> None:
            import sys

            who = holder.describe() if holder is not None else "another process"
            sys.stderr.write(f"[runs] waiting for the shared run store {store}: in use by {who}; the runs it "
                             "finishes are reused here, not computed again\n")

        # a shared store is written by one study at a time: another one waits for it, then reuses its runs
        campaign.run(train + test, progress=progress or False, wait_for_lock_s=SHARED_STORE_WAIT_S if shared else 0.0,
                     on_wait=waiting)
        results = campaign.results(status=None)
        rows = _match_rows(results, train + test)
        ok = rows >= 0
        status = np.array([results.status[i] if i >= 0 else "missing" for i in rows])
        ok &= status == "ok"
        out: dict[str, Any] = {"store": store}
        columns = [c for c in results.outputs if np.issubdtype(np.asarray(results.outputs[c]).dtype, np.number)]
        Y = {c: np.where(ok, np.asarray(results.outputs[c], float)[np.maximum(rows, 0)], np.nan) for c in columns}
        n = len(train)
        X = {k: np.array([p[k] for p in train + test], float) for k in INPUTS}
        out["X_train"] = {k: v[:n] for k, v in X.items()}
        out["X_test"] = {k: v[n:] for k, v in X.items()}
        out["Y_train"] = {c: v[:n] for c, v in Y.items()}
        out["Y_test"] = {c: v[n:] for c, v in Y.items()}
        self._check_runs(fe, store, X, Y)
        return out

    def runs_store(self, key: str) -> Path:
        """The SQLite store of the FE (or simulator) runs of one spec: in the shared run store the study
        was made with (``--run-store``, else `default_run_store`; recorded in its manifest), else in its own
        ``runs/`` folder."""
        shared = self._run_store or (Path(self.manifest.data["run_store"]) if self.manifest.data.get("run_store")
                                     else None)
        return self.layout.runs_store(key) if shared is None else shared / f"runs-{key}.sqlite"

    def _check_runs(self, fe: FESettings, store: Path, X: dict, Y: dict) -> None:
        """Record the content hash of the runs this study used; refuse runs that differ from those recorded.

        A run store may be shared by several studies (and written by them): what each study fitted is pinned
        by the SHA-256 of its runs' inputs and outputs, checked whenever they are read again.
        """
        import hashlib

        def digest(columns) -> str:
            return hashlib.sha256(canonical_json({
                "X": {k: v.tolist() for k, v in sorted(X.items())},
                "Y": {k: [None if not np.isfinite(x) else float(x) for x in Y[k]] for k in sorted(columns)}}
            ).encode()).hexdigest()

        # the results, not the bookkeeping: runs computed again (a deleted cache, another store) read the same
        results = digest([c for c in Y if c not in RUN_BOOKKEEPING_OUTPUTS])
        spec = fe.as_spec()
        key = spec_key({"store": self._store_spec(fe), "n_train": fe.n_train, "n_test": fe.n_test, "seed": fe.seed,
                        "domain": spec.get("domain"), "base_domain": spec.get("base_domain"),
                        **{k: spec[k] for k in ("moduli_per_case", "case_points") if k in spec}})
        used = self.manifest.data.setdefault("fe_runs", {})
        entry = used.get(key)
        if entry is not None:  # recorded by this version (results only) or before it (every output column)
            recorded, found = ((entry["results_sha256"], results) if "results_sha256" in entry
                               else (entry["sha256"], digest(Y)))
            if found != recorded:
                raise UntrustedArtefactError(
                    f"the FE runs read from {store} differ from those this study used (SHA-256 of their inputs and "
                    f"outputs {found[:12]}..., recorded {recorded[:12]}... from {entry['store']}): the store "
                    "was changed or replaced; give the study its own store back, or use a new --study-dir")
        if entry is None or entry["store"] != str(store) or "results_sha256" not in entry:
            used[key] = {"store": str(store), "results_sha256": results, "n_runs": int(next(iter(X.values())).size)}
            self.manifest.write()

    def radius_model(self, fe: FESettings, column: str, workers: int | Executor | None = None, progress=None):
        """The validated radius surrogate of one FE reading (`column`) under `fe`.

        Returns
        -------
        (SurrogateRadiusModel, SurrogateValidation, key)
        """
        return self.radius_models([(fe, column)], workers, progress)[fe, column]

    def _radius_spec(self, fe: FESettings, column: str) -> dict:
        return {"kind": "radius-surrogate", "fe": fe.as_spec(), "store": self._store_spec(fe), "column": column}

    def _recorded_radius_model(self, fe: FESettings, column: str):
        from filmcal._io import read_json
        from filmcal.surrogate import load_surrogate
        from filmcal.surrogate.radius import SurrogateRadiusModel, SurrogateValidation

        key = spec_key(self._radius_spec(fe, column))
        stem = self.layout.surrogate(key)
        paths = (stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz"),
                 self.layout.surrogate_validation(key))
        if not all(self.verified(p) for p in paths):
            return None
        v = read_json(paths[2])
        validation = SurrogateValidation(**v["summary"], details={"points": v["points"]})
        return SurrogateRadiusModel(load_surrogate(stem), fe.domain), validation, key

    def surrogate_validation(self, posterior: Path):
        """The held-out validation (`SurrogateValidation`) of the surrogate a recorded posterior was
        calibrated with (the one its manifest entry names)."""
        from filmcal._io import read_json
        from filmcal.surrogate.radius import SurrogateValidation

        key = (self.manifest.entry(self.layout.relative(posterior)) or {}).get("surrogate")
        path = self.verified(self.layout.surrogate_validation(key)) if key is not None else None
        if path is None:
            raise UntrustedArtefactError(f"the surrogate of {posterior.name} is missing from {self.root}: run "
                                         "the calibration again to refit it")
        v = read_json(path)
        return SurrogateValidation(**v["summary"], details={"points": v["points"]})

    def radius_models(self, requests, workers: int | Executor | None = None, progress=None,
                      transform_rule: str = "evidence") -> dict:
        """Validated radius surrogates of several ``(FESettings, column)``: recorded ones are read, the FE
        runs of the others are run (or resumed) and their surrogates fitted in parallel, each recorded as
        it is done.

        Parameters
        ----------
        requests : sequence of (FESettings, str)
        workers : int or Executor, optional
        progress : callable, optional
            ``progress(done, total, what)``: the FE runs of every campaign counted together
            (``what`` "FE run"), then the surrogate fits ("GP fit").
        transform_rule : {"evidence", "sign"}
            How the fits choose their output transform (`filmcal.surrogate.radius.TRANSFORM_RULES`); recorded.

        Returns
        -------
        dict
            ``(fe, column) -> (SurrogateRadiusModel, SurrogateValidation, key)``.
        """
        from filmcal._parallel import run_tasks
        from filmcal.surrogate.radius import fit_and_validate

        out, tasks, runs = {}, {}, {}
        for fe, column in dict.fromkeys(requests):
            recorded = self._recorded_radius_model(fe, column)
            if recorded is not None:
                out[fe, column] = recorded
        campaigns = list(dict.fromkeys(fe for fe, column in requests if (fe, column) not in out))
        total_runs = sum(fe.n_train + fe.case_runs + fe.n_test for fe in campaigns)
        for fe, column in dict.fromkeys(requests):
            if (fe, column) in out:
                continue
            if fe not in runs:
                before = sum(f.n_train + f.case_runs + f.n_test for f in runs)
                runs[fe] = self.fe_runs(fe, workers, None if not callable(progress) else (
                    lambda done, total, before=before: progress(before + done, max(total_runs, before + total),
                                                                "FE run")))
            r = runs[fe]
            if column not in r["Y_train"] or not np.isfinite(r["Y_train"][column]).any():
                if fe.simulator is not None:
                    raise InputError(f"the simulator ({fe.simulator.label()}) gave no pressure profile "
                                     "(radius_mm, pressure_mpa) to read the other imprint models from: calibrate "
                                     "--imprint-model edge (its contact_radius_mm), or return the profile")
                raise InputError(f"the FE runs have no output {column!r}")
            ytr, yte = r["Y_train"][column], r["Y_test"][column]
            ok_tr, ok_te = np.isfinite(ytr), np.isfinite(yte)
            train = ({k: v[ok_tr] for k, v in r["X_train"].items()}, ytr[ok_tr])
            test = ({k: v[ok_te] for k, v in r["X_test"].items()}, yte[ok_te])
            tasks[fe, column] = (fit_and_validate, (train, test, fe.domain, seed_for(fe.seed, f"gp-{column}"),
                                                    transform_rule))

        fitted_now: list = []

        def store(request, fitted, k) -> None:
            out[request] = self._store_radius_model(*request, *fitted, transform_rule)
            fitted_now.append(request)
            if callable(progress):
                progress(len(fitted_now), len(tasks), "GP fit")

        run_tasks(tasks, workers, store)
        return out

    def _store_radius_model(self, fe: FESettings, column: str, model, validation, transform_rule: str):
        from filmcal._io import atomic_write_json
        from filmcal.surrogate import save_surrogate

        spec = self._radius_spec(fe, column)
        key = spec_key(spec)
        stem = self.layout.surrogate(key)
        vpath = self.layout.surrogate_validation(key)
        stem.parent.mkdir(parents=True, exist_ok=True)
        save_surrogate(model.surrogate, stem)
        atomic_write_json(vpath, {"summary": validation.to_dict(), "points": validation.details["points"],
                                  "column": column}, indent=None)
        for p in (stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz"), vpath):
            self.record(p, "radius-surrogate", spec, column=column, transform_rule=transform_rule)
        return model, validation, key

    # ------------------------------------------------------------ calibration
    def _calibration_spec_dict(self, spec: CalibrationSpec, data_meta: dict) -> dict:
        return {"kind": "posterior", "film": self.film(spec.film).to_dict(), "imprint": spec.imprint,
                "model": spec.model_label, "fe": spec.fe.as_spec(), "loads": spec.loads, "poisson": spec.poisson,
                "discrepancy": spec.discrepancy, "max_steps": spec.max_steps, "dataset": data_meta}

    def calibrate(self, spec: CalibrationSpec, dataset=None, workers: int | Executor | None = None, progress=None):
        """Calibrate one film under one model; reuse the recorded posterior of the same spec.

        Returns
        -------
        (CalibrationResult, Path, dict)
            The result, its file and the spec it was recorded with.
        """
        return self.calibrate_many([spec], dataset, workers, progress)[0]

    def calibrate_many(self, specs, dataset=None, workers: int | Executor | None = None, progress=None, on_done=None):
        """Calibrate several models; recorded posteriors of the same spec are reused, the others are
        sampled in parallel (after their surrogates, `radius_models`), each recorded as it finishes.

        Parameters
        ----------
        specs : sequence of CalibrationSpec
        dataset : str or Path, optional
            The calibration data (default: the study's).
        workers : int or filmcal._parallel.Executor, optional
            Worker processes (default: all cores), or the pool to run in (`filmcal._parallel.SharedPool`).
        progress : callable, optional
            ``progress(done, total, what)`` of the FE runs.
        on_done : callable, optional
            ``on_done(spec, result)`` as each new posterior is recorded.

        Returns
        -------
        list of (CalibrationResult, Path, dict)
            In the order of `specs`.
        """
        from filmcal._parallel import run_tasks
        from filmcal.calibration import load_result
        from filmcal.contact.imprint import imprint_models_for

        results: dict[int, tuple] = {}
        todo = []
        for i, spec in enumerate(specs):
            film = self.film(spec.film)
            if spec.imprint not in imprint_models_for(film):
                raise InputError(f"the {spec.imprint} imprint model cannot read film {film.name} (it reads "
                                 f"{', '.join(imprint_models_for(film))})")
            spec, data, data_meta = self._as_calibrated(spec, dataset)
            full = self._calibration_spec_dict(spec, data_meta)
            path = self.layout.posterior(spec_key(full))
            if self.verified(path):
                results[i] = (load_result(path), path, full)
                self._heal_surrogate(spec, film, path, workers)
            else:
                todo.append((i, spec, film, data, full, path))
        if not todo:
            return [results[i] for i in range(len(specs))]
        from filmcal.calibration import Priors, SamplerSettings, save_result  # the sampler: only to calibrate

        models = self.radius_models([(spec.fe, output_column(spec.imprint, film.name)) for _, spec, film, *_ in todo],
                                    workers, progress)
        self._require_writer()
        tasks, made = {}, {}
        for i, spec, film, data, full, path in todo:
            model, _, skey = models[spec.fe, output_column(spec.imprint, film.name)]
            key = spec_key(full)
            chain = self.layout.chain(key)
            chain.parent.mkdir(parents=True, exist_ok=True)
            path.parent.mkdir(parents=True, exist_ok=True)
            settings = SamplerSettings() if spec.max_steps is None else replace(SamplerSettings(),
                                                                                max_steps=spec.max_steps)
            kwargs = {"film": film.name, "loads": spec.loads, "poisson": spec.poisson, "discrepancy": spec.discrepancy,
                      "priors": Priors.for_film(film, modulus_range_mpa=spec.fe.domain.modulus_mpa),
                      "seed": seed_for(spec.fe.seed, f"chain-{film.name}-{spec.model_label}"), "backend_path": chain,
                      "settings": settings, "progress": False,
                      "rough_flat": _rough_flat(data, film, spec.imprint, spec.fe.kinematics, spec.fe.domain.modulus_mpa)}
            tasks[i] = (_calibrate_call, (data, model, kwargs))
            made[i] = (spec, full, path, skey)

        def record(i, result, k) -> None:
            spec, full, path, skey = made[i]
            save_result(result, path)
            self.record(path, "posterior", full, surrogate=skey)
            results[i] = (result, path, full)
            if on_done is not None:
                on_done(spec, result)

        run_tasks(tasks, workers, record)
        return [results[i] for i in range(len(specs))]

    def as_calibrated(self, spec: CalibrationSpec, dataset=None) -> CalibrationSpec:
        """`spec` as the calibration runs it on the data (default: the study's dataset): its FE design
        covering the data's cases (`_covering_spec`), so that what it names (its surrogate, its posterior)
        is what `calibrate` made. Its domain note is not said again (the calibration said it)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DomainNote)
            return self._as_calibrated(spec, dataset)[0]

    def _as_calibrated(self, spec: CalibrationSpec, dataset=None):
        film = self.film(spec.film)
        data, data_meta = self.dataset_rows(film.name, spec.loads, dataset)
        return _covering_spec(spec, data, film.poisson), data, data_meta

    def _heal_surrogate(self, spec: CalibrationSpec, film: FilmType, posterior: Path, workers) -> None:
        """Refit the surrogate a reused posterior was calibrated with when its files are missing.

        The surrogate is fitted again from the study's recorded FE runs, with
        its seed, so that the sphere corrections and the report, which read it,
        work again; said in one line (`RebuiltNote`) and recorded in the
        manifest's ``rebuilt`` list. A reader (no writer lock) leaves it.
        """
        if not self._lock.held:
            return
        key = (self.manifest.entry(self.layout.relative(posterior)) or {}).get("surrogate")
        if key is None:
            return
        stem = self.layout.surrogate(key)
        files = (stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz"),
                 self.layout.surrogate_validation(key))
        missing = [p for p in files if not p.exists()]
        if not missing:
            return
        column = output_column(spec.imprint, film.name)
        if spec_key(self._radius_spec(spec.fe, column)) != key:
            return  # made under settings that no longer give this key: not this study's to remake
        # refitted under the rule it was made with: one recorded without a rule was made by sign
        rule = next((e["transform_rule"] for p in files if "transform_rule" in (e := self.manifest.entry(
            self.layout.relative(p)) or {})), "sign")
        for p in files:  # the set is remade whole: its other files (checked to be the study's own) go first
            if p.exists():
                self.verified(p)
                p.unlink()
            self.manifest.forget(self.layout.relative(p))
        self.radius_models([(spec.fe, column)], workers, transform_rule=rule)
        self.manifest.data.setdefault("rebuilt", []).append(
            {"artefact": f"surrogates/{key}", "missing": [p.name for p in missing], "when_utc": utc_now()})
        self.manifest.write()
        warnings.warn(RebuiltNote(f"{', '.join(p.name for p in missing)} of surrogate {key} (used by "
                                  f"{posterior.name}) was missing: refitted from the study's recorded FE runs"),
                      stacklevel=2)

    def spec_like_pipeline(self, film: str, imprint_model: str = "edge", kinematics: str = "small",
                           forces_kn: str | None = None) -> CalibrationSpec:
        """The calibration of `film` under one imprint model and film kinematics, on the data of the load range
        `forces_kn` ("50-100"; None: all), with the study's own sizes.

        The FE design sizes, seed and MCMC step cap are those the study's
        pipeline recorded, so that its posteriors are reused; a study made by
        `filmcal calibrate` alone gets that command's defaults.
        """
        from filmcal.surrogate.radius import MODULI_PER_CASE

        recorded = self.manifest.data.get("settings") or {}
        pipeline = recorded.get("pipeline") or {}
        fe = FESettings(kinematics=kinematics, n_train=pipeline.get("train_runs", 200),
                        n_test=pipeline.get("test_runs", 100), seed=recorded.get("seed", 0),
                        film_thickness_mm=self.film(film).thickness_mm,
                        # a pipeline's record leaves it out when 0 (as before it existed); `calibrate`'s default
                        moduli_per_case=pipeline.get("moduli_per_case", 0) if pipeline else MODULI_PER_CASE)
        return CalibrationSpec(film, imprint=imprint_model, fe=fe, loads=forces_kn, max_steps=pipeline.get("max_steps"))

    def dataset_rows(self, film: str, loads: str | None, dataset=None, *, compared: bool = False):
        """The calibration data of one film and the record of their dataset.

        Parameters
        ----------
        film : str
        loads : str or None
            Load range (kN), e.g. ``"50-100"``.
        dataset : str or Path, optional
            A CSV file of the documented dataset format, or a packaged dataset's
            name; default the study's dataset (recorded at its first use), else
            ``table1``.
        compared : bool
            The film's imprint models are to be compared (leave one case out):
            at least 3 cases are needed, not 2.

        Raises
        ------
        filmcal._errors.InputError
            Too few rows or cases, or a dataset other than the study's.
        """
        from filmcal.calibration import load_dataset

        recorded = self.manifest.data.get("dataset")
        if dataset is None:
            if recorded is not None and not recorded["source"].startswith("package:"):
                dataset = recorded["source"]
            else:
                dataset = recorded["name"] if recorded else "table1"
        ds = load_dataset(dataset)
        meta = {k: v for k, v in ds.to_dict().items() if k in ("name", "source", "sha256", "measured_column")}
        if recorded is not None and recorded["sha256"] != meta["sha256"]:
            raise InputError(f"dataset {ds.source} differs from the one this study was made with "
                             f"({recorded['source']}, sha256 {recorded['sha256'][:12]}...); use another --study-dir")
        rows = ds.select(film, loads)
        where = f" with forces in {loads} kN" if loads else ""
        if len(rows) < 2:
            raise InputError(f"dataset {ds.name} has {len(rows)} row(s) of film {film}{where}; a calibration needs "
                             "at least 2 (check --film and --forces-kn)")
        if int(np.unique(rows.case_index).size) < 2:
            raise InputError(f"dataset {ds.name} has {len(rows)} rows of film {film}{where}, all of one case "
                             f"(R {rows.sphere_radius_mm[0]:g} mm, F {rows.force_kn[0]:g} kN): a calibration needs "
                             "at least 2 cases (sphere radius and force) to tell the film's modulus from its scatter")
        if compared and int(np.unique(rows.case_index).size) < 3:
            raise InputError(f"dataset {ds.name} has {int(np.unique(rows.case_index).size)} cases (sphere radius and "
                             f"force) of film {film}{where}: comparing its imprint models leaves one case out at a "
                             "time and needs at least 3; calibrate one imprint model (edge, say) or add cases")
        from filmcal.surrogate.radius import check_supported

        if recorded is None:  # before the study records the dataset: a refused one must not bind the study to it
            try:
                check_supported(rows.sphere_radius_mm, rows.force_kn)
            except ValueError as exc:
                raise InputError(f"the dataset is outside the supported domain: {exc}") from None
        if recorded is None and self._lock.held:
            self.manifest.data["dataset"] = meta
        return rows, meta

    def problem(self, posterior_path: Path):
        """The calibration problem (data, radius model, priors, options) of a recorded posterior."""
        from filmcal.calibration import CalibrationProblem, Priors

        entry = self.manifest.entry(self.layout.relative(posterior_path))
        spec = entry["spec"]
        film = self.film(spec["film"]["name"])
        data, _ = self.dataset_rows(film.name, spec["loads"], spec["dataset"].get("source")
                                    if not spec["dataset"].get("source", "package:").startswith("package:")
                                    else spec["dataset"].get("name", "table1"))
        model = _sphere_model(self, posterior_path)
        priors = Priors.for_film(film, modulus_range_mpa=model.domain.modulus_mpa)
        return CalibrationProblem(data, model, priors, poisson=spec["poisson"],
                                  discrepancy="none" if spec["discrepancy"] is None else spec["discrepancy"],
                                  rough_flat=_rough_flat(data, film, spec["imprint"], spec["fe"]["kinematics"],
                                                         model.domain.modulus_mpa))

    def assess(self, path: Path, result=None):
        """Fit and PSIS-LOO of one recorded posterior (`filmcal.calibration.assess_model`)."""
        from filmcal.calibration import assess_model, load_result
        from filmcal.calibration.posterior import posterior_inference_data

        entry = self.manifest.entry(self.layout.relative(path))
        result = result if result is not None else load_result(self.verified(path))
        problem = self.problem(path)
        label = entry["spec"]["model"]
        return assess_model(problem, posterior_inference_data(problem, result.samples, model_name=label,
                                                              max_draws=500), label)

    def compare(self, film: str, models: dict, *, workers=None, max_steps: int | None = None,
                seed: int = 0, progress=None) -> tuple[dict, bool]:
        """Compare a film's calibrated models by leave-one-case-out accuracy; reuse the recorded comparison.

        Cases whose PSIS estimate is unreliable (Pareto k > 0.7) are refitted
        exactly (`refit_without_case`, with `max_steps` and a seed from `seed`,
        on `workers`); the weights are pseudo-BMA+
        (`filmcal.calibration.compare_models`).

        Parameters
        ----------
        film : str
        models : dict of label -> (CalibrationResult, path, spec)
            At least two posteriors of the film, on the same data.
        progress : callable, optional
            ``progress(done, total)`` after each exact refit.

        Returns
        -------
        (dict, bool)
            `filmcal.calibration.ModelComparison.to_dict` with, per model, its
            posterior summary and per-case predictive residuals
            (``comparison-<film>.json``); and whether it was computed now.
        """
        from filmcal._io import atomic_write_json, read_json
        from filmcal.calibration import compare_models
        from filmcal.calibration.posterior import posterior_inference_data

        path = self.layout.comparison(film)
        spec = {"film": film, "posteriors": sorted(p.name for _, p, _ in models.values()),
                "weights": "pseudo-BMA+, exact refits where Pareto k > 0.7", "max_steps": max_steps, "seed": seed}
        entry = self.manifest.entry(self.layout.relative(path)) if path.exists() else None
        if entry and entry["spec"] == spec and self.verified(path):
            return read_json(path), False
        from functools import partial

        pairs = {}
        for label, (result, ppath, _) in models.items():
            problem = self.problem(ppath)
            pairs[label] = (problem, posterior_inference_data(problem, result.samples, model_name=label,
                                                              max_draws=500))
        refit = partial(refit_without_case, {label: problem for label, (problem, _) in pairs.items()}, film,
                        max_steps, seed_for(seed, f"comparison-{film}"))
        d = compare_models(pairs, refit=refit, workers=workers, random_state=seed, progress=progress).to_dict()
        for label, (result, _, _) in models.items():
            p = result.predictive
            d["models"][label].update(
                modulus_mpa=result.modulus_mpa, oedometric_modulus_mpa=result.oedometric_modulus_mpa,
                sigma_mm=result.sigma_mm, rhat=result.to_dict()["rhat"],
                cases={"sphere_radius_mm": p.sphere_radius_mm, "force_kn": np.asarray(p.force_n) / 1e3,
                       "standardized_residual": p.standardized_residual, "inside_90": ~np.asarray(p.outside)})
        atomic_write_json(path, d, indent=1)
        self.record(path, "comparison", spec)
        return read_json(path), True

    # ------------------------------------------------------------ reading posteriors
    def posteriors(self, film: str | None = None, **match: Any) -> list[tuple[Path, dict]]:
        """Recorded posteriors (file, spec), optionally of one film and matching spec fields.

        `match` takes ``imprint``, ``model``, ``loads``, ``poisson``, ``discrepancy``
        and FE fields (``kinematics``, ``sphere_contact``, ``flat_contact``,
        ``friction_coefficient``, ``seed``, ``n_train``, ``n_test``); a value of
        None matches anything, except that without ``loads`` the posteriors of
        all loads are taken when there are also some of a load range. Posteriors
        of an older revision of the in-house FE (`FE_MODEL_REVISION`; a folder
        run again after an update keeps them) are stale and never returned, and
        one made on the design alone is superseded by one of the same settings
        whose surrogate also has runs at the data's cases (`FESettings.case_points`;
        a folder calibrated again after an update keeps both).
        """
        out = []
        for rel, entry in self.manifest.artefacts("posterior").items():
            spec = entry["spec"]
            if film is not None and spec["film"]["name"] != film:
                continue
            if "simulator" not in spec["fe"] and spec["fe"].get("fe_model_revision", 1) != FE_MODEL_REVISION:
                continue
            if all(v is None or (spec["fe"].get(k, spec.get(k)) if k in spec["fe"] else spec.get(k)) == v
                   for k, v in match.items()):
                out.append((self.root / rel, spec))
        if match.get("loads") is None and len({s.get("loads") is None for _, s in out}) == 2:
            out = [(p, s) for p, s in out if s.get("loads") is None]  # no load range asked: all loads first
        return _without_superseded(out)

    def calibrate_command(self, film: str, **match: Any) -> str:
        """The `filmcal calibrate` command that makes the posterior of `film` matching `match` in this study, at
        the FE design sizes, seed and step cap its pipeline recorded (`calibration_spec`: the same spec)."""
        import shlex

        recorded = self.manifest.data.get("settings") or {}
        pipeline = recorded.get("pipeline") or {}
        words = ["filmcal", "calibrate", "--film", film, "--study-dir", str(self.root)]
        for key, value in match.items():
            if value is not None and key in _MATCH_OPTIONS:
                words += [_MATCH_OPTIONS[key], str(value)]
        if pipeline:
            words += ["--train-runs", str(pipeline.get("train_runs", 200)), "--test-runs",
                      str(pipeline.get("test_runs", 100)), "--moduli-per-case", str(pipeline.get("moduli_per_case", 0))]
            if pipeline.get("max_steps") is not None:
                words += ["--max-steps", str(pipeline["max_steps"])]
        if recorded.get("seed", 0):
            words += ["--seed", str(recorded["seed"])]
        return shlex.join(words)

    def posterior(self, film: str, **match: Any):
        """The one recorded posterior of `film` matching `match`; a clear error when none or several.

        Returns
        -------
        (CalibrationResult, Path, dict)
        """
        from filmcal.calibration import load_result

        self.film(film)
        found = self.posteriors(film, **match)
        if not found:
            asked = ", ".join(f"{_MATCH_WORDS.get(k, k)} {v}" for k, v in match.items() if v is not None)
            raise InputError(f"study {self.root} has no posterior of {film}" + (f" with {asked}" if asked else "")
                             + f": make it with `{self.calibrate_command(film, **match)}` first")
        if len(found) > 1:
            keys = sorted({k for _, s in found for k in _spec_fields(s)
                           if len({json_key(_spec_fields(t).get(k)) for _, t in found}) > 1})
            raise InputError(f"study {self.root} has {len(found)} posteriors of {film} that differ in "
                             f"{', '.join(keys)}; choose one with those options")
        path, spec = found[0]
        self.verified(path)
        return load_result(path), path, spec


class RebuiltNote(UserWarning):
    """A missing artefact was made again by the stage that makes it (what, and from what)."""


class DomainNote(UserWarning):
    """The study's design was extended to cover a dataset's cases (how many new FE runs it costs)."""


def _bodies_spec(spec: "CalibrationSpec", data) -> "CalibrationSpec":
    """`spec` with the FE's bodies those of the data: steel (as before), or the one material of every row's
    sphere and flat; rows of different bodies are refused in one line before any FE work (the FE models the
    sphere and the flat of one material, and one surrogate per material)."""
    cols = [np.asarray(getattr(data, k), float) for k in ("sphere_modulus_mpa", "sphere_poisson",
                                                           "flat_modulus_mpa", "flat_poisson")]
    values = {tuple(v) for v in zip(*cols)}
    if len(values) > 1 or any(e != e2 or nu != nu2 for e, nu, e2, nu2 in values):
        shown = "; ".join(f"sphere {e:g} MPa / {nu:g}, flat {e2:g} MPa / {nu2:g}" for e, nu, e2, nu2 in
                          sorted(values)[:3])
        raise InputError(f"dataset: the bodies of film {spec.film}'s rows differ ({shown}): the FE models a sphere "
                         "and a flat of one material, the same in every row; calibrate rows of other bodies in "
                         "another study")
    (e, nu, _, _), = values
    if (e, nu) == (STEEL_MODULUS_MPA, STEEL_POISSON):
        return spec
    if spec.fe.simulator is not None:
        raise InputError(f"film {spec.film}: the dataset's bodies are not steel ({e:g} MPa, {nu:g}), and a lab's "
                         "simulator is not told the bodies: give it rows of its own bodies' material")
    return replace(spec, fe=replace(spec.fe, body_modulus_mpa=float(e), body_poisson=float(nu)))


def _covering_spec(spec: "CalibrationSpec", data, poisson: float) -> "CalibrationSpec":
    """`spec` with its FE domain extended to cover the data's cases (`SurrogateDomain.covering`), said first;
    a case outside the supported domain is refused in one line before any FE work. The FE's bodies are the
    data's (`_bodies_spec`), and its training design gains runs along ln E at each of the data's cases at the
    film's Poisson ratio (`_with_case_points`)."""
    import warnings

    spec = _with_case_points(_bodies_spec(spec, data), data, poisson)

    try:
        domain = spec.fe.domain.covering(data.sphere_radius_mm, np.asarray(data.force_n, float) / 1e3)
    except ValueError as exc:
        raise InputError(f"the dataset is outside the supported domain: {exc}") from None
    if domain is spec.fe.domain:
        return spec
    from filmcal.surrogate.radius import augmented_samples

    levels = ", ".join(f"{r:g}" for r in domain.radius_levels_mm)
    base = spec.fe.domain
    new = augmented_samples(domain, base, spec.fe.n_train) + augmented_samples(domain, base, spec.fe.n_test)
    warnings.warn(DomainNote(
        f"the dataset's cases lie outside the design's domain: it is extended to sphere radii {levels} mm and "
        f"forces {domain.force_kn[0]:.3g}-{domain.force_kn[1]:.3g} kN, {new} new FE runs per film kinematics "
        + (f"besides the {spec.fe.case_runs} at the data's cases " if spec.fe.case_runs else "") +
        f"(the design is augmented: the {spec.fe.n_train + spec.fe.n_test} runs over the domain it extends are "
        "reused)"), stacklevel=3)
    return replace(spec, fe=replace(spec.fe, domain=domain, base_domain=base))


def _with_case_points(spec: "CalibrationSpec", data, poisson: float) -> "CalibrationSpec":
    """`spec` with its FE runs at the data's distinct (R, F) cases at `poisson`: ``moduli_per_case`` each,
    fewer when the cases are many (at most ``n_train`` runs in all; none below 2 a case)."""
    lo, hi = spec.fe.domain.poisson
    if spec.fe.moduli_per_case == 0 or not lo <= poisson <= hi:
        return spec
    cases = sorted({(float(r), round(float(f) / 1e3, 9)) for r, f in zip(data.sphere_radius_mm, data.force_n)})
    k = min(spec.fe.moduli_per_case, spec.fe.n_train // max(len(cases), 1))
    points = tuple((r, f, float(poisson)) for r, f in cases) if k >= 2 else ()
    return replace(spec, fe=replace(spec.fe, moduli_per_case=k if points else 0, case_points=points))


def _rough_flat(data, film, imprint: str, kinematics: str, modulus_range_mpa):
    """The film model's rough-flat growth when `data` has rows measured on a roughened flat (else None)."""
    ra = data.flat_ra_um
    if ra is None or not np.any(np.isfinite(ra) & (np.asarray(ra, float) > 0)):
        return None
    from filmcal.calibration.roughness import RoughFlatGrowth
    from filmcal.contact.film import FilmModel

    return RoughFlatGrowth(FilmModel(film, imprint, kinematics), tuple(modulus_range_mpa))


def _calibrate_call(data, model, kwargs: dict):
    """`filmcal.calibration.calibrate` as a worker's task."""
    from filmcal.calibration import calibrate

    return calibrate(data, model, **kwargs)


def _flatten(d: dict, prefix: str = "") -> dict:
    """Nested settings as ``{"a.b": value}``."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def json_key(value: Any) -> str:
    import json

    return json.dumps(value, sort_keys=True, default=str)


def _case_runs(spec: dict) -> int:
    return len(spec["fe"].get("case_points", ())) * int(spec["fe"].get("moduli_per_case", 0))


def _without_superseded(found: list[tuple[Path, dict]]) -> list[tuple[Path, dict]]:
    """`found` without the posteriors made on the design alone where one of the same settings otherwise has
    runs at the data's cases (its surrogate is exact where the calibration asks it)."""
    design = ("case_points", "moduli_per_case")

    def settings(spec: dict) -> str:
        return json_key({"film": spec.get("film"), "dataset": spec.get("dataset"),
                         **{k: v for k, v in _spec_fields(spec).items() if k not in design}})

    with_cases = {settings(s) for _, s in found if _case_runs(s)}
    return [(p, s) for p, s in found if _case_runs(s) or settings(s) not in with_cases]


def _spec_fields(spec: dict) -> dict:
    fields = {k: v for k, v in spec.items() if k not in ("fe", "film", "kind", "dataset")}
    fields.update(spec["fe"])
    return fields


def _match_rows(results, points: list[dict]) -> np.ndarray:
    """Index of each point's row in the campaign results (-1 when missing)."""
    from filmcal.surrogate.radius import INPUTS

    opts = ("sphere_contact", "flat_contact", "kinematics")

    def key_of(get) -> tuple:
        return tuple(round(float(get(n)), 9) for n in INPUTS) + tuple(str(get(o)) for o in opts)

    n = len(results.status)
    index = {}
    for i in range(n):
        index[key_of(lambda name: results.inputs[name][i])] = i
    return np.array([index.get(key_of(p.__getitem__), -1) for p in points])


def refit_without_case(problems: dict, film: str, max_steps: int | None, seed: int, label: str, data):
    """Model `label` calibrated again on `data` (a fold without one case): its samples.

    The exact refit of a leave-one-case-out term, for the comparison and the cross-validation.
    """
    from filmcal.calibration import SamplerSettings, calibrate

    problem = problems[label]
    sampler = SamplerSettings() if max_steps is None else SamplerSettings(max_steps=max_steps)
    return calibrate(data, problem.model, film=film, poisson=problem.poisson_mode,
                     discrepancy=None if problem.discrepancy == "none" else problem.discrepancy,
                     priors=problem.priors, seed=seed_for(seed, label), settings=sampler,
                     rough_flat=problem.rough_flat).samples


def comparison_weights(study: Study, film: str) -> dict[str, float]:
    """Stacking weights of the film's models (model label -> weight), when the study compared them."""
    from filmcal._io import read_json

    path = study.layout.comparison(film)
    if not study.verified(path):
        return {}
    return {k: float(v) for k, v in (read_json(path).get("weights") or {}).items()}


def _sphere_model(study: Study, posterior_path: Path, *, predict_only: bool = False):
    """The radius surrogate that a recorded posterior was calibrated with.

    With `predict_only` the surrogate is read for prediction alone
    (`filmcal.surrogate.saved`: numpy, no scikit-learn), as a correction needs it.
    """
    from filmcal.surrogate.radius import SurrogateDomain, SurrogateRadiusModel

    entry = study.manifest.entry(study.layout.relative(posterior_path))
    stem = study.layout.surrogate(entry["surrogate"])
    domain = SurrogateDomain(**{k: tuple(v) for k, v in entry["spec"]["fe"]["domain"].items()})
    for p in (stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz")):
        if study.verified(p) is None:
            raise InputError(f"{p} is missing: the surrogate of {posterior_path.name}; run `filmcal calibrate` again "
                             "to recompute it")
    if predict_only:
        from filmcal.surrogate.radius import load_for_prediction

        return SurrogateRadiusModel(load_for_prediction(stem), domain)
    from filmcal.surrogate import load_surrogate

    return SurrogateRadiusModel(load_surrogate(stem), domain)


def chosen_posteriors(study: Study, film: str, *, model: str | None = None,
                      **match: Any) -> list[tuple[float, Path, dict]]:
    """The recorded posteriors a correction of `film` uses, with their weights: ``[(weight, path, spec)]``.

    With `model` (``"activation/small"``) or filters that leave one posterior,
    that posterior alone (weight 1). Otherwise, when the study compared the
    film's models, every compared model with its combination weight: the
    correction is then their mixture. Several posteriors and no comparison is
    an error that names the options that tell them apart.
    """
    # in the order of the models' names, not of the manifest (which follows the workers' finishing order):
    # a mixture's draws, and so its answer, must not depend on which calibration finished first
    found = sorted(study.posteriors(film, model=model, **match), key=lambda ps: (ps[1]["model"], ps[0].name))
    if not found:
        study.posterior(film, model=model, **match)  # raises the message that says what to run
    for path, _ in found:
        if not path.is_file():  # recorded, then deleted: only the command that made it makes it again
            from filmcal.study.manifest import remake_hint

            raise InputError(f"{path} is recorded in the study but missing; {remake_hint(study.root, 'posterior')}")
    if len(found) == 1:
        return [(1.0, found[0][0], found[0][1])]
    weights = comparison_weights(study, film) if model is None else {}
    chosen = [(weights[s["model"]], p, s) for p, s in found if weights.get(s["model"], 0) > 0]
    if not chosen or len({s["model"] for _, _, s in chosen}) != len(chosen):
        study.posterior(film, model=model, **match)  # several and no comparison: says which options differ
    return chosen


def film_model(study: Study, spec: dict):
    """The `filmcal.contact.film.FilmModel` that a recorded posterior was calibrated under."""
    from filmcal.contact.film import FilmModel

    return FilmModel(study.film(spec["film"]["name"]), spec["imprint"], spec["fe"]["kinematics"])


def curve_components(study: Study, film: str, *, model: str | None = None, **match: Any) -> list[tuple]:
    """``[(FilmModel, modulus samples, weight)]`` of a film, for `filmcal.correction.correction_curves`."""
    from filmcal.calibration import load_result

    from filmcal.correction.wheelrail import nominal_modulus_mpa

    out = []
    for w, path, spec in chosen_posteriors(study, film, model=model, **match):
        fm = film_model(study, spec)
        study.verified(path, kind="posterior", spec=spec)
        out.append((fm, nominal_modulus_mpa(load_result(path).samples, fm.film.poisson), w))
    return out


def growth_modulus_of(study: Study, parts: list) -> float:
    """The modulus (MPa) at which the rough growths of these correctors' film are solved
    (`filmcal.correction.roughness.growth_modulus_mpa`), from their whole posteriors as the pipeline's rough
    curves take it (`curve_components`): the two then share their rough laws (`StudyRoughLaws`)."""
    from filmcal.correction.roughness import growth_modulus_mpa
    from filmcal.correction.wheelrail import nominal_modulus_mpa

    return growth_modulus_mpa([(c.film, nominal_modulus_mpa(_posterior_samples(study.root / s["posterior_file"]),
                                                            c.film.film.poisson), w) for w, c, s in parts])


def _posterior_samples(path: Path) -> dict[str, np.ndarray]:
    """The posterior samples of a recorded calibration result (`read_posterior_samples`: the one reader)."""
    from filmcal.calibration.result_file import read_posterior_samples

    return read_posterior_samples(path)


def _profile_spec(profile: str) -> Any:
    """A wheel or rail profile as a cache spec names it: its name, or a CSV file's SHA-256."""
    from filmcal._io import sha256_file

    path = Path(str(profile))
    return {"file_sha256": sha256_file(path)} if path.is_file() else str(profile)


class _StudySupports:
    """Wheel-rail support areas kept in the study, one file per (offset, force, models).

    ``posteriors/<key>-supports.json`` beside the posteriors, ``<key>`` the
    hash of its spec: the posteriors (their SHA-256), the film and
    kinematics, the transfer fit, the application model's revision, the wheel-rail settings (a profile file
    by its SHA-256), the support moduli, the offset and the force. The manifest records each file
    with its spec and SHA-256 under ``caches``, not among the artefacts: a
    cache is no result of the study (the report and its inputs, and a
    pipeline run, ignore it). A recorded file is verified as an artefact is
    (changed: refused, naming it); an unrecorded one is not read. Written
    only when the study's writer lock is free: a study being written by
    another process, or a read-only folder, leaves the solves uncached.
    """

    KIND = "wheel-rail-supports"

    def __init__(self, study: Study, posteriors: dict[str, str]) -> None:
        self.study = study
        self.posteriors = posteriors  # model label -> SHA-256 of its posterior file
        self.pending: list = []  # solves kept by `flush`, once the answer they served is given

    def _spec(self, offset_mm: float, force_n: float, support) -> dict:
        from filmcal.contact import names
        from filmcal.contact.transfer import load_transfer_fit

        settings = {k: (_profile_spec(v) if k in ("wheel", "rail") else v) for k, v in support.settings.items()}
        transfer = load_transfer_fit()
        return _json_roundtrip({"kind": self.KIND, "film": support.models[0].film.to_dict(),
                                "application_model_revision": names.APPLICATION_MODEL_REVISION,
                                "transfer": {m.label: transfer.digest(m.label) for m in support.models},
                                "kinematics": support.models[0].kinematics,
                                "posteriors": {m.label: self.posteriors[m.label] for m in support.models},
                                "wheel_rail": settings, "moduli_mpa": [float(e) for e in support.moduli_mpa],
                                "offset_mm": float(offset_mm), "force_n": float(force_n)})

    def _path(self, spec: dict) -> Path:
        key = spec_key(spec)
        return self.study.layout.posterior(key).with_name(f"{key}-supports.json")

    def get(self, offset_mm: float, force_n: float, support) -> dict | None:
        spec = self._spec(offset_mm, force_n, support)
        areas = _read_cache(self.study, self._path(spec), spec)
        if not isinstance(areas, dict) or set(areas.get("area_film_mm2", {})) != {m.label for m in support.models}:
            return None
        return areas

    def put(self, offset_mm: float, force_n: float, support, areas: dict) -> None:
        """Keep the solves when `flush` is called (an input refused after its solve writes nothing)."""
        spec = self._spec(offset_mm, force_n, support)
        self.pending.append((self._path(spec), spec, areas))

    def flush(self) -> None:
        """Write the solves kept since the last flush into the study."""
        for path, spec, areas in self.pending:
            _write_cache(self.study, path, spec, areas, "filmcal correct: keeping wheel-rail solves")
        self.pending.clear()


class StudyGrowths:
    """Rough/smooth growths of a film's models kept in the study, one file per configuration and roughness.

    ``posteriors/<key>-roughness.json``, ``<key>`` the hash of its spec: the posteriors (SHA-256), the
    wheel-rail settings, the offset and force, the bodies (each Ra, a measured surface by its fingerprint),
    the draws of the roughness inputs (shipped, or the study's own), the modulus the growths were solved at
    (`growth_modulus_of`), the application model's revision.
    Recorded under the manifest's ``caches`` and verified like `_StudySupports`; written only when the writer
    lock is free.
    """

    KIND = "wheel-rail-roughness"

    def __init__(self, study: Study, parts: list) -> None:
        self.study = study
        self.parts = parts
        self.pending: list = []  # growths kept by `flush`, once the answer they served is given

    def spec(self, offset_mm: float, force_n: float, bodies: dict, draws: list, modulus_mpa: float) -> dict:
        from filmcal.contact import names
        from filmcal.contact.waviness import WAVINESS_CUTOFF_CELLS
        from filmcal.wheelrail.settings import FILM_MIN_CELLS_ACROSS

        settings = {k: (_profile_spec(v) if k in ("wheel", "rail") else v)
                    for k, v in self.parts[0][1].settings.items()}
        return _json_roundtrip({"kind": self.KIND, "posteriors": {s["model"]: s.get("posterior_sha256")
                                                                  for _, _, s in self.parts},
                                "wheel_rail": settings, "offset_mm": float(offset_mm), "force_n": float(force_n),
                                "bodies": bodies, "draws": [d.to_dict() for d in draws],
                                "growth_modulus_mpa": float(modulus_mpa),
                                "waviness_cutoff_cells": WAVINESS_CUTOFF_CELLS,
                                "film_min_cells_across": FILM_MIN_CELLS_ACROSS,
                                "application_model_revision": names.APPLICATION_MODEL_REVISION})

    def _path(self, spec: dict) -> Path:
        key = spec_key(spec)
        return self.study.layout.posterior(key).with_name(f"{key}-roughness.json")

    def get(self, spec: dict) -> dict | None:
        data = _read_cache(self.study, self._path(spec), spec)
        return data if isinstance(data, dict) and set(data) == set(spec["posteriors"]) else None

    def put(self, spec: dict, data: dict) -> None:
        """Keep the growths when `flush` is called."""
        self.pending.append((self._path(spec), spec, data))

    def flush(self) -> None:
        """Write the growths kept since the last flush into the study."""
        for path, spec, data in self.pending:
            _write_cache(self.study, path, spec, data, "filmcal correct: keeping rough wheel-rail solves")
        self.pending.clear()


def rough_law_spec(bodies, film: FilmType | None, modulus_mpa: float | None) -> dict:
    """What makes one rough boundary-element law (`filmcal.contact.roughness.Roughness.film_law`, or
    ``steel_law`` with ``film`` None): the bodies' micro surfaces (the SHA-256 of their heights and pixel), the
    film, its modulus and hardness, and the application model's revision. The pipeline's rough curves,
    `filmcal correct` and `filmcal curves` key their laws by it, so that each reuses the others'
    (``roughlaws/<key>.npz``)."""
    import hashlib

    from filmcal.contact import names

    def surface(s) -> str | None:
        if s is None:
            return None
        digest = hashlib.sha256(np.ascontiguousarray(s.heights_um, dtype=float).tobytes())
        digest.update(repr((s.heights_um.shape, float(s.pixel_um))).encode())
        return digest.hexdigest()

    return _json_roundtrip({"kind": StudyRoughLaws.KIND, "film": None if film is None else film.to_dict(),
                            "modulus_mpa": None if film is None else float(modulus_mpa),
                            "hardness_mpa": None if film is None else float(bodies.film_hardness_mpa),
                            "surfaces_sha256": [surface(bodies.wheel), surface(bodies.rail)],
                            "application_model_revision": names.APPLICATION_MODEL_REVISION})


class StudyRoughLaws:
    """The rough bodies' boundary-element laws kept in a study, one ``roughlaws/<key>.npz`` per
    `rough_law_spec`, each kept as soon as it is solved: a rough correction or curve interrupted after some
    of its laws (each is seconds to minutes) solves only the others when run again.

    A law the pipeline recorded (kind ``rough-law``, an artefact) is read as it is; one solved by `filmcal
    correct` or `filmcal curves` (``command``: the writer lock's label) is recorded under the manifest's
    ``caches`` (written only when the writer lock is free, as `StudyGrowths`), and the pipeline takes it over
    as its artefact (`Study.adopt`).
    """

    KIND = "rough-law"

    def __init__(self, study: Study, command: str = "filmcal correct") -> None:
        self.study = study
        self.command = command

    def spec_path(self, bodies, film: FilmType | None, modulus_mpa: float | None) -> tuple[dict, Path]:
        """The `rough_law_spec` of a law and the file that holds it in the study."""
        spec = rough_law_spec(bodies, film, modulus_mpa)
        return spec, self.study.layout.rough_law(spec_key(spec))

    def kept(self, bodies, film: FilmType | None, modulus_mpa: float | None) -> Path | None:
        """The file of the law of `rough_law_spec` when the study has it (the pipeline's, or one kept and
        unchanged since), else None: a kept law changed since is solved again, as the pipeline does (`held`);
        a changed artefact of the pipeline's is refused. Bodies without a micro part (all waviness) have none."""
        if bodies.wheel is None and bodies.rail is None:
            return None
        spec, path = self.spec_path(bodies, film, modulus_mpa)
        if self.study.manifest.entry(self.study.layout.relative(path)) is not None:  # the pipeline's
            return path if self.study.verified(path, kind=self.KIND, spec=spec) else None
        try:
            return path if _read_cache(self.study, path, spec, read=lambda p: p) is not None else None
        except InputError:  # changed since it was kept (not a result of the study's): solved again
            return None

    def add(self, bodies, film: FilmType | None, modulus_mpa: float | None, law) -> Path | None:
        """Keep a solved law under its `rough_law_spec`: the file written, or None where none was (the writer lock
        taken, a read-only folder, an artefact of the pipeline's there since, no micro part)."""
        from filmcal.contact.rough_law_file import save_rough_law

        if bodies.wheel is None and bodies.rail is None:
            return None
        spec, path = self.spec_path(bodies, film, modulus_mpa)
        written = _write_cache(self.study, path, spec, law, f"{self.command}: keeping a rough law",
                               write=save_rough_law)
        return path if written else None

    def law(self, bodies, film: FilmType | None, modulus_mpa: float | None, solve):
        """The law of `rough_law_spec`: read back from the study, or ``solve()`` and kept."""
        from filmcal.contact.rough_law_file import load_rough_law

        path = self.kept(bodies, film, modulus_mpa)
        if path is not None:
            return load_rough_law(path)
        law = solve()
        self.add(bodies, film, modulus_mpa, law)
        return law

    def held(self, path: Path, spec: dict) -> bool:
        """Whether the pipeline (holding the writer lock) has the law of `spec` at `path` as its artefact: its
        own, or one `law` kept, taken over (`Study.adopt`). A file recorded nowhere (a write interrupted before
        its record) or a kept law changed since is not held: the pipeline solves it again and records it."""
        relpath = self.study.layout.relative(path)
        if self.study.manifest.entry(relpath) is not None:
            return self.study.verified(path, kind=self.KIND, spec=spec) is not None
        try:
            return self.study.adopt(path, self.KIND, spec) is not None
        except InputError:  # changed since it was kept: solved again
            self.study.manifest.data["caches"].pop(relpath, None)
            return False


def _read_cache(study: Study, path: Path, spec: dict, read=None):
    """A cache file the study recorded with this spec, read by ``read`` (default: as JSON); None when absent or
    made for another spec. A file changed since is refused, naming it."""
    from filmcal._io import read_json, sha256_file

    entry = (study.manifest.data.get("caches") or {}).get(study.layout.relative(path))
    if entry is None or entry.get("spec") != spec or not path.exists():
        return None
    if sha256_file(path) != entry.get("sha256"):
        raise InputError(f"{path} was changed after the study wrote it (SHA-256 differs from the manifest); "
                         "delete it and run again to recompute it")
    return (read or read_json)(path)


def _write_cache(study: Study, path: Path, spec: dict, data: Any, what: str, write=None) -> bool:
    """Keep `data` in the study under the manifest's ``caches`` (kind, spec, SHA-256), written by ``write(data,
    path)`` (default: as JSON), under the writer lock taken briefly as `what`; whether it was kept (not when the
    lock is taken, the folder is read-only or the study has its own artefact there)."""
    from filmcal._io import atomic_write_json, sha256_file

    try:
        with study.writing(what, brief=True):
            if study.manifest.entry(study.layout.relative(path)) is not None:
                return False  # an artefact of the study's own since it was read (a pipeline's): never overwritten
            path.parent.mkdir(parents=True, exist_ok=True)
            if write is None:
                atomic_write_json(path, data)
            else:
                write(data, path)
            caches = study.manifest.data.setdefault("caches", {})
            caches[study.layout.relative(path)] = {"kind": spec["kind"], "spec": spec, "sha256": sha256_file(path),
                                                   "written_utc": utc_now()}
            study.manifest.write()
        return True
    except (InputError, OSError):
        return False  # the writer lock is taken or the folder is read-only: nothing is kept


def _results_sha256(manifest: dict) -> str:
    """SHA-256 of a manifest's canonical JSON without its ``caches``."""
    import hashlib

    return hashlib.sha256(canonical_json({k: v for k, v in manifest.items() if k != "caches"}).encode()).hexdigest()


def _json_roundtrip(value: Any) -> Any:
    """`value` as it reads back from the manifest's JSON (tuples as lists, numpy as plain numbers)."""
    import json

    from filmcal._json import json_safe

    return json.loads(json.dumps(json_safe(value)))


def correctors(study: Study, film: str, kind: str = "sphere", *, model: str | None = None, random_state=0,
               wheel_rail: dict | None = None, **match: Any) -> list[tuple[float, Any, dict]]:
    """The correctors of a film, built from the study's recorded posteriors: ``[(weight, corrector, spec)]``.

    Which posteriors: `chosen_posteriors`. Never calibrates. Sphere-on-flat
    correctors predict with the saved radius surrogates (numpy alone);
    wheel-rail correctors of one film kinematics share their solves (one per
    modulus serves every imprint reading), and the study keeps the solved
    areas per (offset, force, models) when its writer lock is free.

    Parameters
    ----------
    kind : {"sphere", "wheel-rail"}
    wheel_rail : dict, optional
        Wheel-rail model settings (wheel, rail, rail_inclination, nominal_radius_mm).
    """
    if kind not in ("sphere", "wheel-rail"):
        raise InputError(f"kind must be sphere or wheel-rail, got {kind!r}")
    out = []
    hashes = {}
    for w, path, spec in chosen_posteriors(study, film, model=model, **match):
        study.verified(path)
        samples = _posterior_samples(path)
        if kind == "sphere":
            from filmcal.correction.sphere import SphereCorrector

            corrector = SphereCorrector(_sphere_model(study, path, predict_only=True), samples,
                                        random_state=random_state)
        else:
            from filmcal.correction.wheelrail import WheelRailCorrector

            corrector = WheelRailCorrector(samples, film_model(study, spec), random_state=random_state,
                                           **(wheel_rail or {}))
            hashes[corrector.film.label] = study.manifest.entry(study.layout.relative(path))["sha256"]
        rel = study.layout.relative(path)
        out.append((w, corrector, dict(spec, posterior_file=rel,
                                       posterior_sha256=study.manifest.entry(rel)["sha256"])))
    if kind == "wheel-rail":
        from filmcal.correction.wheelrail import WheelRailCorrector

        WheelRailCorrector.share_supports([c for _, c, _ in out], cache=_StudySupports(study, hashes))
    return out


def report_view(study: Study) -> dict:
    """What the report reads of a study: its settings and the files of each stage (None when missing).

    Returns
    -------
    dict
        ``config`` (films, seed, settings, hash), ``posteriors`` {film: path}
        (the film's preferred model: the highest stacking weight, else the
        first recorded), ``surrogate`` (stem of the edge surrogate of the
        first kinematics) and ``surrogate_validation``, ``verification``,
        ``design``, ``outlines`` (paths), ``crossval``, ``curves``,
        ``comparison`` ({film: path}).
    """
    settings = study.manifest.data.get("settings") or {}
    films = list(study.manifest.data.get("pipeline_films") or sorted(
        {s["film"]["name"] for s in (e["spec"] for e in study.manifest.artefacts("posterior").values())}))
    seed = settings.get("seed", 0)
    config = {"films": films, "seed": seed, "settings": settings.get("pipeline", settings),
              "hash": spec_key(settings or {"films": films}),
              "software": study.manifest.data.get("software"),
              "software_later": study.manifest.data.get("software_later", [])}
    posteriors, used = {}, set()
    for film in films:
        found = study.posteriors(film)
        used |= {(study.manifest.entry(study.layout.relative(p)) or {}).get("surrogate") for p, _ in found}
        if not found:
            continue
        weights = comparison_weights(study, film)
        best = max(weights, key=weights.get) if weights else None
        pick = [p for p, s in found if s["model"] == best] or [p for p, s in found if s["imprint"] == "edge"] \
            or [found[0][0]]
        posteriors[film] = pick[0]
    surrogate = validation = None
    # an edge surrogate a current posterior was calibrated with (not one of a superseded design)
    edge = [(rel, e) for rel, e in study.manifest.artefacts("radius-surrogate").items()
            if e.get("column") == "contact_radius_mm" and rel.endswith(".json") and not rel.endswith("-validation.json")
            and Path(rel).stem in used]
    if edge:
        rel = edge[0][0]
        surrogate = study.root / rel[: -len(".json")]
        validation = study.layout.surrogate_validation(Path(rel).stem)

    def existing(p):
        return p if p is not None and p.exists() else None

    return {"config": config, "posteriors": posteriors, "surrogate": surrogate,
            "surrogate_validation": existing(validation), "verification": existing(study.layout.verification),
            "design": existing(study.layout.design), "outlines": existing(study.layout.outlines),
            "crossval": {f: study.layout.crossval(f) for f in films if study.layout.crossval(f).exists()},
            "curves": {f: study.layout.curves(f) for f in films if study.layout.curves(f).exists()},
            "comparison": {f: study.layout.comparison(f) for f in films if study.layout.comparison(f).exists()}}
