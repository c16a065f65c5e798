"""The machinery every task shares: the registry (:mod:`.registry`), the job context a task's
run function gets (:mod:`.context`), input expansion (:mod:`.inputs`), parameter resolution
(:mod:`.resolve`), one job (:mod:`.execute`) and its log (:mod:`.joblog`), the executors that run
jobs here or in worker processes (:mod:`.executors`), and running a task (:mod:`.run`)."""
