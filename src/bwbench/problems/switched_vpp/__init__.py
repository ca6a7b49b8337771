"""problems/switched_vpp"""
