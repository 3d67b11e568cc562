"""What `mirrorscan plan` prints: the plan written, its predicted figures and the hand-made
layout it was compared with."""

from __future__ import annotations

from pathlib import Path

from .message import Message


def plan_written(folder: Path, plan: dict) -> Message:
    """The plan folder written.

    Parameters
    ----------
    folder : Path
        The plan folder.
    plan : dict
        Its plan.json object.

    Returns
    -------
    Message
    """
    predicted, hand = plan["predicted"], plan["hand_made"]
    gain = 100 * (predicted["coverage"] - hand["predicted"]["coverage"])
    shape = "V" if hand["kind"] == "v" else "arc"
    details = [
        f"coverage {100 * predicted['coverage']:.1f} %, seen by two or more views "
        f"{100 * predicted['coverage_2']:.1f} %",
        "per view: " + ", ".join(
            f"{name} {100 * share:.1f} % at {_mm(predicted['noise_mm'][name])}"
            for name, share in predicted["per_view"].items()),
        f"best symmetric {shape}: {hand['angle_deg']:.0f} degrees, reach {hand['reach']:.2f} m, "
        f"coverage {100 * hand['predicted']['coverage']:.1f} %",
        f"camera tilted down {plan['camera']['tilt_deg']:.1f} degrees, subject "
        f"{plan['search']['distance']:.2f} m ahead",
    ]
    return Message(
        f"wrote the plan {folder}: it sees {100 * predicted['coverage']:.1f} % of the subject, "
        f"{gain:+.1f} points against the best symmetric {shape}; build it from drawing.png.",
        tuple(details),
    )


def _mm(value: float | None) -> str:
    """A noise in mm, or 'no reading' for a view that sees nothing."""
    return "no reading" if value is None else f"{value:.1f} mm"
