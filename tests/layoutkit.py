"""Racers' downloads as their producers write them, for the layout tests: every file in its real
format, every figure consistent with the others, so that a test can check each fact a record
states against what the files say.

The formats follow the public simulation application (deepracer-simapp) and the public sample
downloads of deepracer-utils and deepracer-log-guru:

- an evaluation's metrics file holds one entry per lap, as the simulator appends it: its start and
  end in the simulation's milliseconds, the elapsed time between them (the pauses of penalties
  included: an off-track holds the car for ``OFF_TRACK_PENALTY`` seconds, a collision for
  ``COLLISION_PENALTY``), the status label, and the counts of each reset's cause;
- the job's log (RoboMaker's for the console, ``-simulation.log`` for DeepRacer on AWS) prints the
  job's parameters as a Python dict, the model metadata key it loaded, the ``Sensor list`` line,
  the action space, the hyperparameters block (for an evaluation, the evaluation worker's
  defaults), and one ``SIM_TRACE_LOG`` line per step at 15 steps a second, of 19 columns;
- a training job's SageMaker log prints the model's own hyperparameters and ``Training>`` lines;
- logs of 2019 print the parameters ROS-style only and trace lines of 15 columns;
- CloudWatch's CSV export holds one ``timestamp,message`` row per log line.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

STEP_S = 1 / 15
DROA_PREFIX = "[download_params_and_roslaunch_agent.py-1] [run_evaluation_rl_agent.sh-9] "
DROA_TRAINING_PREFIX = "[download_params_and_roslaunch_agent.py-1] [run_rollout_rl_agent.sh-9] "
#: What an evaluation job prints as "its" hyperparameters: the evaluation worker's defaults.
EVALUATION_WORKER_PPO = {"batch_size": 64, "beta_entropy": 0.01, "discount_factor": 0.999,
                         "e_greedy_value": 0.05, "epsilon_steps": 10000,
                         "exploration_type": "categorical", "loss_type": "mean squared error",
                         "lr": 0.0003, "num_episodes_between_training": 20, "num_epochs": 10,
                         "stack_size": 1, "term_cond_avg_score": 100000.0,
                         "term_cond_max_episodes": 100000}
EVALUATION_WORKER_SAC = {key: value for key, value in EVALUATION_WORKER_PPO.items()
                         if key not in ("beta_entropy", "num_epochs")} | {"sac_alpha": 0.2}


def actions(*pairs: tuple[float, float]) -> list[dict[str, float]]:
    """A discrete action space of (steering angle, speed) pairs, indexed."""
    return [{"steering_angle": angle, "speed": speed, "index": index}
            for index, (angle, speed) in enumerate(pairs)]


FIVE_ACTIONS = actions((-30.0, 1.2), (-15.0, 2.0), (0.0, 3.0), (15.0, 2.0), (30.0, 1.2))


def metadata(space: Any = None, *, algorithm: str = "clipped_ppo", version: str | int = "5",
             sensors: tuple[str, ...] = ("FRONT_FACING_CAMERA",)) -> dict[str, Any]:
    space = FIVE_ACTIONS if space is None else space
    return {"action_space": space, "sensor": list(sensors),
            "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW", "version": version,
            "training_algorithm": algorithm,
            "action_space_type": "discrete" if isinstance(space, list) else "continuous"}


def hyperparameters(**changes: Any) -> dict[str, Any]:
    """A model's own hyperparameters, as ip/hyperparameters.json holds them: unlike the
    evaluation worker's in every field a design comparison shows."""
    return {"batch_size": 128, "beta_entropy": 0.005, "discount_factor": 0.95,
            "e_greedy_value": 0.05, "epsilon_steps": 10000, "exploration_type": "categorical",
            "loss_type": "huber", "lr": 0.0005, "num_episodes_between_training": 25,
            "num_epochs": 4, "stack_size": 1, "term_cond_avg_score": 100000.0,
            "term_cond_max_episodes": 100000, **changes}


# ------------------------------------------------------------------ one evaluation's laps


@dataclass(frozen=True)
class LapSpec:
    """A lap: seconds of driving, how it ended, and the resets on the way."""

    driving_s: float
    end: str = "lap_complete"  # or off_track, crashed (the lap ends there)
    off_tracks: int = 0  # off-tracks the car was reset after, each held OFF_TRACK_PENALTY
    crashes: int = 0
    progress: float = 100.0  # where a lap that does not complete ends


@dataclass(frozen=True)
class Evaluation:
    laps: tuple[LapSpec, ...]
    off_track_penalty_s: float = 2.0
    collision_penalty_s: float = 5.0
    continuous: bool = False
    first_start_s: float = 6.2


@dataclass
class _TimedLap:
    spec: LapSpec
    start_s: float
    end_s: float
    steps: list[tuple[float, str, float, float]] = field(default_factory=list)  # t, status, pause, progress


def _timeline(evaluation: Evaluation) -> list[_TimedLap]:
    laps, start = [], evaluation.first_start_s
    for number, spec in enumerate(evaluation.laps, start=1):
        timed = _TimedLap(spec, start, start)
        driving_steps = max(2, round(spec.driving_s / STEP_S))
        resets = ["off_track"] * spec.off_tracks + ["crashed"] * spec.crashes
        reset_at = {round(driving_steps * (n + 1) / (len(resets) + 1)): cause
                    for n, cause in enumerate(resets)}
        t = start
        final_progress = 100.0 if spec.end == "lap_complete" else spec.progress
        for step in range(1, driving_steps + 1):
            t += STEP_S
            progress = final_progress * step / driving_steps
            last = step == driving_steps
            status = ("prepare" if step == 1 else "in_progress") if not last else (
                "in_progress" if evaluation.continuous and spec.end == "lap_complete" and
                number < len(evaluation.laps) else spec.end)
            timed.steps.append((t, status, 0.0, progress))
            if step in reset_at and not last:
                cause = reset_at[step]
                penalty = (evaluation.off_track_penalty_s if cause == "off_track"
                           else evaluation.collision_penalty_s)
                timed.steps[-1] = (t, cause, penalty, progress)
                held = round(penalty / STEP_S)
                for hold in range(1, held + 1):
                    t += STEP_S
                    timed.steps.append((t, "pause", max(0.0, penalty - hold * STEP_S), progress))
        timed.end_s = t
        laps.append(timed)
        start = t if evaluation.continuous else t + 0.55
    return laps


def lap_times_ms(evaluation: Evaluation) -> list[int]:
    """Each lap's time as the metrics file states it: its start to its end, penalties included."""
    return [round((lap.end_s - lap.start_s) * 1000) for lap in _timeline(evaluation)]


_LABELS = {"lap_complete": "Lap complete", "off_track": "Off track", "crashed": "Crashed",
           "in_progress": "In progress"}


def evaluation_metrics(evaluation: Evaluation) -> str:
    entries = []
    timeline = _timeline(evaluation)
    for trial, lap in enumerate(timeline, start=1):
        spec = lap.spec
        off_track = spec.off_tracks + (spec.end == "off_track")
        crashes = spec.crashes + (spec.end == "crashed")
        continuing = evaluation.continuous and spec.end == "lap_complete" and trial < len(timeline)
        entries.append({
            "completion_percentage": int(100 if spec.end == "lap_complete" else spec.progress),
            "metric_time": round(lap.end_s * 1000), "start_time": round(lap.start_s * 1000),
            "elapsed_time_in_milliseconds": round((lap.end_s - lap.start_s) * 1000),
            "episode_status": _LABELS["in_progress" if continuing else spec.end],
            "crash_count": crashes, "immobilized_count": 0, "off_track_count": off_track,
            "reversed_count": 0, "reset_count": off_track + crashes, "trial": trial,
        })
    return json.dumps({"metrics": entries})


def trace(evaluation: Evaluation, *, track_len: float = 23.12, old_format: bool = False) -> list[str]:
    """The evaluation's SIM_TRACE_LOG lines (the 2019 format has 15 columns, no status)."""
    lines = []
    timeline = _timeline(evaluation)
    for episode, lap in enumerate(timeline):
        for step, (t, status, pause, progress) in enumerate(lap.steps, start=1):
            angle = 2 * math.pi * progress / 100
            x, y = 3.2 * math.cos(angle), 1.6 * math.sin(angle)
            done = step == len(lap.steps) and not (status == "in_progress" and lap is not timeline[-1])
            waypoint = round(progress * 1.18) % 118
            columns = (f"{episode},{step},{x:.4f},{y:.4f},{math.degrees(angle):.4f},-15.00,2.00,1,"
                       f"1.0000,{done},True,{progress:.4f},{waypoint},{track_len:.2f},{t:.3f}")
            if not old_format:
                columns += f",{status},{pause:.2f},0,{1714557600 + t:.4f}"
            lines.append("SIM_TRACE_LOG:" + columns)
    return lines


# ------------------------------------------------------------------ logs


def evaluation_log(params: dict[str, Any], evaluation: Evaluation, *, space: Any = None,
                   sensor_line: bool = True, metadata_key: str | None = None, prefix: str = "",
                   algorithm: str = "clipped_ppo", version: str = "5.0") -> str:
    """An evaluation job's log: its parameters, the model it loaded, what it printed of it, the
    evaluation worker's hyperparameters and the trace. ``space=False`` prints no action space."""
    space = FIVE_ACTIONS if space is None else space
    key = metadata_key or f"{params.get('MODEL_S3_PREFIX', 'models/m')}/model/model_metadata.json"
    worker = EVALUATION_WORKER_SAC if algorithm == "sac" else EVALUATION_WORKER_PPO
    lines = [
        "Executing simulation-entrypoint.sh script",
        f"WORLD_NAME={params.get('WORLD_NAME')}",
        f"NUMBER_OF_TRIALS={params.get('NUMBER_OF_TRIALS')}",
        "[s3] Successfully downloaded yaml file from s3 key models/abc/eval_params.yaml to local "
        "./custom_files/eval_params.yaml.",
        repr(params),
        f"[s3] Successfully downloaded model metadata                  from s3 key {key} to local "
        "./custom_files/agent/model_metadata.json.",
        "SUMMARY", "========", "PARAMETERS",
        *(f" * /{name}: {str(value)[:17] + '...' if len(str(value)) > 20 else value}"
          for name, value in sorted(params.items()) if not isinstance(value, list)),
        "+ python3 -m markov.evaluation_worker",
    ]
    if sensor_line:
        lines.append(f"Sensor list ['FRONT_FACING_CAMERA'], network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, "
                     f"simapp_version {version}, training_algorithm {algorithm}, action_space_type "
                     f"{'discrete' if isinstance(space, list) else 'continuous'} lidar_config "
                     "{'num_sectors': 8, 'num_values_per_sector': 8, 'clipping_dist': 2.0}")
    if space is not False:
        lines.append(f"Action space from file: {space!r}")
    lines += ["Using the following hyper-parameters",
              *json.dumps(worker, indent=2, sort_keys=True).splitlines(),
              "agent: Starting evaluation phase", "Reset agent", *trace(evaluation),
              f"[s3] Successfully uploaded metrics to                  s3 bucket b with s3 key "
              f"{_first(params.get('METRICS_S3_OBJECT_KEY'))}.",
              "agent: Finished evaluation phase. Success rate = 0.0, Avg Total Reward = 194.6",
              "Cancelling the current running simulation job"]
    return "".join(f"{prefix}{line}\n" for line in lines)


def training_log(space: Any, hyper: dict[str, Any], *, episodes: int = 40,
                 algorithm: str = "clipped_ppo") -> str:
    """A training job's SageMaker log: what it printed of the model, the model's
    hyperparameters, and a line per episode."""
    lines = [
        f"Sensor list ['FRONT_FACING_CAMERA'], network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, "
        f"simapp_version 5.0, training_algorithm {algorithm}, action_space_type "
        f"{'discrete' if isinstance(space, list) else 'continuous'} lidar_config "
        "{'num_sectors': 8, 'num_values_per_sector': 8, 'clipping_dist': 2.0}",
        f"Action space from file: {space!r}",
        "Using the following hyper-parameters",
        *json.dumps(hyper, indent=2, sort_keys=True).splitlines(),
        "[s3] Successfully uploaded hyperparameters to                  s3 bucket b with s3 key "
        "models/abc/ip/hyperparameters.json.",
        *(f"Training> Name=main_level/agent, Worker=0, Episode={n}, Total reward={n * 3}, "
          f"Steps={n * 25}, Training iteration={n // 20}" for n in range(1, episodes + 1)),
    ]
    return "".join(line + "\n" for line in lines)


def ros_log_2019(params: dict[str, Any], evaluation: Evaluation) -> str:
    """A 2019 RoboMaker evaluation log: parameters ROS-style only, long values cut short, the
    older action-space line and trace lines of 15 columns."""
    lines = ["SUMMARY", "========", "", "PARAMETERS",
             *(f" * /{name}: {str(value)[:17] + '...' if len(str(value)) > 20 else value}"
               for name, value in sorted(params.items()) if not isinstance(value, list)),
             " * /rosdistro: kinetic", " * /rosversion: 1.12.14", "",
             f"Loaded action space from file: {FIVE_ACTIONS!r}",
             *trace(evaluation, old_format=True)]
    return "".join(line + "\n" for line in lines)


def cloudwatch_csv(log_text: str) -> str:
    """A CloudWatch log stream exported as CSV: one timestamp,message row per line."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["@timestamp", "@message"])
    for number, line in enumerate(log_text.splitlines()):
        minute, second, millisecond = number // 60000 % 60, number // 1000 % 60, number % 1000
        writer.writerow([f"2024-05-01 10:{minute:02d}:{second:02d}.{millisecond:03d}", line])
    return out.getvalue()


# ------------------------------------------------------------------ training


def training_metrics(episodes: int, *, first_start_ms: int = 28_000, evaluations_every: int = 20) -> str:
    """A training metrics file: training episodes, and the evaluation episodes between
    iterations; timestamps in the simulation's milliseconds."""
    entries, t = [], first_start_ms
    for episode in range(1, episodes + 1):
        elapsed = 4000 + (episode * 137) % 9000
        completion = min(100, 5 + episode * 3 % 100)
        entries.append({"reward_score": round(episode * 1.5, 1), "metric_time": t + elapsed, "start_time": t,
                        "elapsed_time_in_milliseconds": elapsed, "episode": episode,
                        "trial": (episode - 1) % evaluations_every + 1, "phase": "training",
                        "completion_percentage": completion,
                        "episode_status": "Lap complete" if completion == 100 else "Off track"})
        t += elapsed + 400
        if episode % evaluations_every == 0:
            entries.append({"reward_score": 0, "metric_time": t + 9000, "start_time": t,
                            "elapsed_time_in_milliseconds": 9000, "episode": episode, "trial": 1,
                            "phase": "evaluation", "completion_percentage": 60,
                            "episode_status": "Off track"})
            t += 9400
    return json.dumps({"metrics": entries})


def training_span_s(text: str) -> float:
    entries = json.loads(text)["metrics"]
    return round((max(e["metric_time"] for e in entries) - min(e["start_time"] for e in entries)) / 1000, 1)


# ------------------------------------------------------------------ params


def console_yaml(values: dict[str, Any]) -> str:
    """A console params file: every value a quoted string."""
    return "---\n" + "".join(f'{key}: "{_first(value)}"\n' for key, value in values.items())


def typed_yaml(values: dict[str, Any]) -> str:
    """A DeepRacer-for-Cloud or DeepRacer on AWS params file: typed values, lists as lists."""
    lines = ["---"]
    for key, value in values.items():
        if isinstance(value, list):
            lines += [f"{key}:"] + [f"- {json.dumps(item)}" for item in value]
        else:
            lines.append(f"{key}: {json.dumps(value)}")
    return "\n".join(lines) + "\n"


def _first(value: Any) -> Any:
    return value[0] if isinstance(value, list) and value else value


def write(path: Path, text: str | dict[str, Any]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text if isinstance(text, str) else json.dumps(text, indent=2))
    return path
