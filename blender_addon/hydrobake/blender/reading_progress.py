"""What a bake shows while it steps the scene through its frames on the main thread, before
its thread starts (a deforming mesh sampled over a long range can take a minute): Blender's
progress cursor in the UI, a line every few seconds in background mode. (In the UI the
operator reads from a timer and shows Esc to cancel in the status bar: jobs.Reading.)"""
import time

import bpy


def step_text(frame, done, total):
    """A reading step as words: "frame 12 (3/40)", or what it made ("the shape of Rock (1/2)")
    where ``frame`` is a text."""
    what = frame if isinstance(frame, str) else f"frame {frame}"
    return f"{what} ({done}/{total})"


class ReadingProgress:
    """Called (frame, done, total) for each frame a Reading takes; close() lets the cursor
    go."""
    EVERY = 5.0  # s between lines in background mode
    AFTER = 0.5  # s before the cursor shows: most bakes read their frames sooner

    def __init__(self, label, busy):
        self.label = label  # "Object/effect", as the command line's frame lines say
        self.busy = busy  # another bake's progress shows: the cursor is left to it
        self.t0 = self.last = time.monotonic()
        self.shown = False

    def __call__(self, frame, done, total):
        now = time.monotonic()
        if bpy.app.background:
            if now - self.last >= self.EVERY:
                self.last = now
                print(f"hydrobake: {self.label} reading the scene: "
                      f"{step_text(frame, done, total)} elapsed {now - self.t0:.1f}s",
                      flush=True)
            return
        if self.busy or now - self.t0 < self.AFTER:
            return
        wm = bpy.context.window_manager
        if not self.shown:
            wm.progress_begin(0, 1000)
            self.shown = True
        wm.progress_update(int(1000 * done / total))

    def close(self):
        if self.shown:
            self.shown = False
            bpy.context.window_manager.progress_end()
