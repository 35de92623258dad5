"""Job logs in the formats the DeepRacer simulation application and trainer write them, for tests.

Modelled on the public console and DeepRacer on AWS log downloads (deepracer-utils' test data):
the environment dump, the job's parameters printed as a Python dict, the sensor line, ``Action
space from file:``, the hyperparameters block and one ``SIM_TRACE_LOG:`` line per step
(episode, step, x, y, heading, steering, speed, action, reward, done, all_wheels_on_track,
progress, closest_waypoint, track_len, tstamp, episode_status, pause_duration). DeepRacer on AWS
prefixes every line with the processes it went through.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

DROA_PREFIX = "[download_params_and_roslaunch_agent.py-1] [run_evaluation_rl_agent.sh-9] "
ACTIONS = [{"steering_angle": angle, "speed": speed, "index": index}
           for index, (angle, speed) in enumerate([(-30.0, 1.0), (-15.0, 2.0), (0.0, 3.0),
                                                    (15.0, 2.0), (30.0, 1.0)])]
HYPERPARAMETERS = {"batch_size": 64, "beta_entropy": 0.01, "discount_factor": 0.999,
                   "e_greedy_value": 0.05, "epsilon_steps": 10000, "exploration_type": "categorical",
                   "loss_type": "huber", "lr": 0.0003, "num_episodes_between_training": 20,
                   "num_epochs": 10, "stack_size": 1, "term_cond_avg_score": 100000.0,
                   "term_cond_max_episodes": 100000}


def job_params(job_type: str = "EVALUATION", *, world: str = "reInvent2019_track",
               racer: str = "Pitstop", model: str = "pitstop-v3", race_type: str = "TIME_TRIAL",
               metrics_key: str = "models/abc/metrics/evaluation/evaluation-20240501101010-Q.json",
               **extra: Any) -> dict[str, Any]:
    return {"METRICS_S3_BUCKET": ["aws-deepracer-data-us-east-1-1"], "AWS_REGION": "us-east-1",
            "RACER_NAME": racer, "VIDEO_JOB_TYPE": job_type, "RACE_TYPE": race_type,
            "WORLD_NAME": world, "MODEL_NAME": model, "NUMBER_OF_TRIALS": "3",
            "MODEL_METADATA_FILE_S3_KEY": ["models/abc/model/model_metadata.json"],
            "BODY_SHELL_TYPE": ["deepracer"], "JOB_TYPE": job_type,
            "METRICS_S3_OBJECT_KEY": [metrics_key], "NUMBER_OF_RESETS": "10000",
            "IS_CONTINUOUS": "false", "CAR_COLOR": ["Black"], **extra}


def trace(laps: list[tuple[float, str]], *, step_s: float = 1 / 15, start_s: float = 6.2,
          track_len: float = 23.12) -> list[str]:
    """SIM_TRACE_LOG lines of laps given as (seconds, final status); a lap that goes off track
    spends a few steps off_track midway."""
    lines, tstamp = [], start_s
    for episode, (seconds, final) in enumerate(laps):
        steps = round(seconds / step_s)
        progress_at_end = 100.0 if final == "lap_complete" else 47.3
        for step in range(1, steps + 1):
            done = step == steps
            status = final if done else ("prepare" if step == 1 else "in_progress")
            if final != "lap_complete" and not done and steps // 2 <= step < steps // 2 + 3:
                status = "off_track"
            progress = progress_at_end * step / steps
            lines.append(f"SIM_TRACE_LOG:{episode},{step},3.1999,0.6831,0.1858,-15.00,2.00,1,"
                         f"1.0000,{done},True,{progress:.4f},{step % 118},{track_len:.2f},"
                         f"{tstamp:.3f},{status},0.00")
            tstamp += step_s
        tstamp += 0.5  # the car is put back on the start line
    return lines


def simulation_log(params: dict[str, Any], laps: list[tuple[float, str]] | None = None, *,
                   prefix: str = "", actions: Any = None) -> str:
    lines = [
        "Executing simulation-entrypoint.sh script",
        f"WORLD_NAME={params['WORLD_NAME']}",
        "[s3] Successfully downloaded yaml file from s3 key models/abc/eval_params.yaml to local "
        "./custom_files/eval_params.yaml.",
        repr(params),
        "Sensor list ['FRONT_FACING_CAMERA'], network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, "
        "simapp_version 5.0, training_algorithm clipped_ppo, action_space_type discrete "
        "lidar_config {'num_sectors': 8, 'num_values_per_sector': 8, 'clipping_dist': 2.0}",
        "SUMMARY", "========", "PARAMETERS", f" * /RACER_NAME: {params['RACER_NAME']}",
        f" * /WORLD_NAME: {params['WORLD_NAME']}",
        f"Action space from file: {ACTIONS if actions is None else actions!r}",
        "Using the following hyper-parameters",
        *json.dumps(HYPERPARAMETERS, indent=2).splitlines(),
        "agent: Starting evaluation phase",
        *trace(laps or []),
        "agent: Finished evaluation phase. Success rate = 0.0, Avg Total Reward = 200.5",
        "Cancelling the current running simulation job",
    ]
    return "".join(f"{prefix}{line}\n" for line in lines)


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def console_log_download(folder: Path, laps: list[tuple[float, str]] | None = None,
                         **params: Any) -> Path:
    """A console "download logs" folder: the evaluation's RoboMaker log and the training's
    SageMaker log, no metrics files and no model_metadata.json."""
    write(folder / "logs" / "evaluation" / "evaluation-20240501101010-QkJ3xYz-robomaker.log",
          simulation_log(job_params(**params), laps or [(16.4, "lap_complete"),
                                                        (9.0, "off_track"),
                                                        (15.8, "lap_complete")]))
    write(folder / "logs" / "training" / "training-20240501080000-Tr41nXyZ-sagemaker.log",
          f"Action space from file: {ACTIONS!r}\nUsing the following hyper-parameters\n"
          + json.dumps(HYPERPARAMETERS, indent=2) + "\nTraining> Name=main_level/agent\n")
    return folder
