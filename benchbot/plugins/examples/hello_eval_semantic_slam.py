"""hello_eval_semantic_slam: submit each scene's ground truth as the object map (OMQ must be 1.0).

This reads the ground truth through BenchBot's registry: a pipeline check, never a solution.
"""

from benchbot_api import Agent, BenchBot

from benchbot.core.registry import get_registry
from _example_io import write_results


class HelloEval(Agent):
    def is_done(self, action_result):
        return True  # no motion needed

    def pick_action(self, observations, action_list):
        raise AssertionError("never called: is_done is always True")

    def save_result(self, filename, empty_results, results_format_fns):
        results = empty_results["results"]
        class_list = results["class_list"]
        for env in empty_results["environment_details"]:
            gt = get_registry().ground_truth(f"{env['name']}:{env['variant']}")["ground_truth"]
            for obj in gt["objects"]:
                probs = [0.0] * len(class_list)
                probs[class_list.index(obj["class"])] = 1.0
                results["objects"].append({"label_probs": probs, "centroid": obj["centroid"], "extent": obj["extent"]})
        write_results(filename, empty_results)


if __name__ == "__main__":
    BenchBot(agent=HelloEval()).run()
