"""A training stage's progress bar on stderr: "Enet 12/100 epochs", the stage's ETA, the
last validation loss, and what the stages still to come add (the overall ETA)."""

from __future__ import annotations

import sys
import time

from lightning.pytorch.callbacks import Callback
from tqdm import tqdm

_FORMAT = "{desc} {n_fmt}/{total_fmt} epochs |{bar}| {elapsed}<{remaining}{postfix}"


class StageBar(Callback):
    """One tick per epoch. `later` lists the (name, epochs) of the stages after this one:
    their epochs are not timed yet, so the bar says they follow instead of guessing; in the
    last stage the ETA is the overall one. Both are upper bounds: early stopping may end a
    stage sooner."""

    def __init__(self, name: str, epochs: int, stage: int, stages: int, later: tuple[tuple[str, int], ...] = ()):
        self.name, self.epochs, self.stage, self.stages, self.later = name, epochs, stage, stages, later
        self.bar = None
        self.t0 = 0.0

    def _tail(self, trainer) -> str:
        parts = []
        loss = trainer.callback_metrics.get("val_loss")
        if loss is not None:
            parts.append(f"val_loss {float(loss):.4g}")
        if self.later:
            parts.append("then " + ", ".join(f"{n} {e} epochs" for n, e in self.later))
        elif self.stages > 1:
            parts.append("ETA is overall")
        return f"stage {self.stage}/{self.stages}" + "".join(f" · {p}" for p in parts)

    def on_train_start(self, trainer, pl_module) -> None:
        if not trainer.is_global_zero:
            return
        self.t0 = time.perf_counter()
        self.bar = tqdm(
            total=self.epochs, desc=self.name, file=sys.stderr, dynamic_ncols=True, bar_format=_FORMAT, leave=True
        )
        self.bar.set_postfix_str(self._tail(trainer), refresh=True)

    def on_train_epoch_end(self, trainer, pl_module) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(self._tail(trainer), refresh=False)
            self.bar.update(1)

    def on_train_end(self, trainer, pl_module) -> None:
        if self.bar is None:
            return
        if self.bar.n < self.epochs:
            self.bar.set_postfix_str(f"{self._tail(trainer)} · stopped early", refresh=False)
        self.bar.close()
        self.bar = None

    def on_exception(self, trainer, pl_module, exception) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
