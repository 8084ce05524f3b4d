"""hello_passive: follow the passive trajectory to its end, save a few images, submit an empty map."""

from benchbot_api import ActionResult, Agent, BenchBot
from benchbot_api.benchbot import RESULT_LOCATION

from _example_io import image_folder, save_png, write_results

SAVE_EVERY = 10  # steps between saved images


class HelloPassive(Agent):
    def __init__(self) -> None:
        self.step = 0
        self.folder = image_folder(RESULT_LOCATION)

    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS

    def pick_action(self, observations, action_list):
        if self.step % SAVE_EVERY == 0:
            save_png(self.folder / f"rgb_{self.step:04d}.png", observations["image_rgb"])
            save_png(self.folder / f"depth_{self.step:04d}.png", observations["image_depth"])
        self.step += 1
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        print(f"followed {self.step} trajectory poses; images in {self.folder}")
        write_results(filename, empty_results)


if __name__ == "__main__":
    BenchBot(agent=HelloPassive()).run()
