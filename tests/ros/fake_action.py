"""An rclpy action server that stands in for another project's (a gripper controller, a grasp planner) in the
tests: it records each goal and cancel, accepts a goal (or rejects it while `reject` is set), and ends it at once
with `finish(handle)`'s result (or, while `hold` is set, keeps it executing until it is canceled)."""
from __future__ import annotations

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.task import Future


class FakeActionServer:
    def __init__(self, node, action_type, name: str):
        self.type = action_type
        self.goals: list = []
        self.cancels = 0
        self.reject = False
        self.hold = False
        self.released: Future | None = None
        self.server = ActionServer(node, action_type, name, execute_callback=self._execute,
                                   goal_callback=self._goal, cancel_callback=self._cancel)

    def finish(self, handle):
        """The result of a goal not held; ends the goal (succeeded by default)."""
        handle.succeed()
        return self.type.Result()

    def _goal(self, goal):
        self.goals.append(goal)
        return GoalResponse.REJECT if self.reject else GoalResponse.ACCEPT

    def _cancel(self, _handle):
        self.cancels += 1
        if self.released is not None:
            self.released.set_result(True)
        return CancelResponse.ACCEPT

    async def _execute(self, handle):
        if self.hold:
            self.released = Future()
            await self.released
            handle.canceled()
            return self.type.Result()
        return self.finish(handle)
