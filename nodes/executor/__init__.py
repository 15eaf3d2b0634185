"""The executor: plan actions as streamed TCP setpoints, with the loop closed on perception."""
