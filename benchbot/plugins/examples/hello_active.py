"""hello_active: drive a fixed square, save the RGB image after each action, submit an empty map."""

from benchbot_api import ActionResult, Agent, BenchBot
from benchbot_api.benchbot import RESULT_LOCATION

from _example_io import image_folder, save_png, write_results

PLAN = [("move_distance", {"distance": 0.5}), ("move_angle", {"angle": 90.0})] * 4


class HelloActive(Agent):
    def __init__(self) -> None:
        self.step = 0
        self.folder = image_folder(RESULT_LOCATION)

    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS or self.step >= len(PLAN)

    def pick_action(self, observations, action_list):
        save_png(self.folder / f"rgb_{self.step:04d}.png", observations["image_rgb"])
        action = PLAN[self.step]
        self.step += 1
        return action

    def save_result(self, filename, empty_results, results_format_fns):
        print(f"performed {self.step} actions; images in {self.folder}")
        write_results(filename, empty_results)


if __name__ == "__main__":
    BenchBot(agent=HelloActive()).run()
