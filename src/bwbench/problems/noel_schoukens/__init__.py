"""problems/noel_schoukens"""
